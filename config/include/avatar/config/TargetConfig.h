#pragma once
/// @file TargetConfig.h
/// Colour filter, feature locator and search window of each target type
/// (thesis 3.3, 4.2.4).

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace avatar {

/// A closed interval [min, max]; min <= max is enforced by validation.
struct Range {
    double min{0.0};
    double max{0.0};
    bool contains(double v) const { return min <= v && v <= max; }
    bool operator==(const Range& o) const { return min == o.min && max == o.max; }
};

/// A rectangle of the image in pixels. width or height 0 means "the whole image".
struct SearchWindow {
    int x{0};
    int y{0};
    int width{0};
    int height{0};
    bool wholeImage() const { return width == 0 || height == 0; }
    bool operator==(const SearchWindow& o) const {
        return x == o.x && y == o.y && width == o.width && height == o.height;
    }
};

/// Which colour filter a target type uses.
enum class ColorFilterMethod {
    RgbRatio,  ///< R/G, R/B, B/G ranges (thesis Figure 3-8)
    Hsv        ///< hue/saturation/value ranges (the thesis's proposed alternative)
};

/// Hue in degrees [0, 360), saturation and value in [0, 1]. A hue range with
/// min > max wraps through 0 (e.g. 340..20 for red).
struct HsvRanges {
    Range hue{0.0, 360.0};
    Range saturation{0.0, 1.0};
    Range value{0.0, 1.0};
    bool operator==(const HsvRanges& o) const {
        return hue == o.hue && saturation == o.saturation && value == o.value;
    }
};

/// The shape model of a target type (docs/config.md, <shape>): how its
/// silhouettes are checked for completeness and its position computed.
/// - None: nothing known; the centroids are triangulated.
/// - Sphere: each silhouette must fit a sphere's (the image of a circular
///   cone); the cone axes are triangulated, which removes the centroid's bias.
/// - Disc: a flat circle; each silhouette must fit an ellipse, and the image
///   of the circle's centre (not the ellipse's centre) is triangulated.
/// - Composite: a rigid object of round parts (the duck: a body and a head
///   sphere); each silhouette must be explained by at most two parts, the
///   largest checked as a sphere's, and the largest part's cone axes are
///   triangulated (the duck's centre is its body's).
enum class TargetShape { None, Sphere, Disc, Composite };

/// RGB-ratio ranges for the pixels of one brightness band (thesis 3.3.2:
/// "multiple ratio maximum/minimum values depending on the overall
/// magnitude"): a pixel whose M = R+G+B lies in `brightness` is judged by
/// these three ranges instead of the type's own, so clusters that part along
/// a diagonal of ratio against M (the dark lab of 6.3) can be separated.
struct BrightnessBand {
    Range brightness;  ///< M, in the units of the image's samples
    Range redGreen;
    Range redBlue;
    Range blueGreen;
    bool operator==(const BrightnessBand& o) const {
        return brightness == o.brightness && redGreen == o.redGreen && redBlue == o.redBlue &&
               blueGreen == o.blueGreen;
    }
};

/// The veil a target's colour may be seen through (haze, thesis 3.6.1): light
/// scattered back by the water towards the camera adds the water's colour V
/// to every pixel, the more the farther the object. A pixel of a target seen
/// through it is t J + (1 - t) V, so its ratio point (R/G, B/G) lies on the
/// segment from the target's own colour's towards V's; `maxShare` bounds the
/// veil's share of the pixel's G. With a veil, an RGB-ratio type accepts,
/// besides what its ranges accept, every colour of the veil's ranges (its
/// own by default, cut by its R/B range) mixed with V up to that share: the
/// convex hull, in the (R/G, B/G) plane, of that region and the region moved
/// towards V by `maxShare`; all within its brightness range.
struct Veil {
    std::array<double, 3> colourRgb{0.0, 1.0, 0.0};  ///< R, G, B of the backscatter as the cameras see it; any scale, G > 0
    double maxShare{0.0};                            ///< the veil's largest share of a pixel's G, in (0, 1)
    /// The colour the veil acts on (the target's in clear water), when
    /// narrower than the type's ranges (which may follow the water's
    /// absorption too); unset: the type's own.
    std::optional<Range> redGreen;
    std::optional<Range> blueGreen;
    bool operator==(const Veil& o) const {
        return colourRgb == o.colourRgb && maxShare == o.maxShare && redGreen == o.redGreen &&
               blueGreen == o.blueGreen;
    }
};

/// The water a target's colour may be seen through (thesis 3.6.1): it absorbs
/// each channel c as exp(-k_c L) over the light's path L (lamp -> target ->
/// camera, about twice the range with the lamps beside the cameras), red
/// first in blue-green water, so a target's R/G is scaled by
/// exp(-(k_R - k_G) L) and its B/G by exp(-(k_B - k_G) L): the farther the
/// target, the further its colour leaves its clear-water ranges. A site's
/// water changes (plankton, silt, the season), and so may each channel's
/// absorption: with a water, an RGB-ratio type accepts, besides what its
/// ranges accept, every colour of the water's ranges (its own by default)
/// seen through up to `maxPathM` of any water that takes R/G and B/G each at
/// most as far as this one: the water's ranges with the far end of each
/// ratio moved by this water over `maxPathM` (R/B not checked), within its
/// brightness range.
struct Water {
    /// k_R, k_G, k_B of the murkiest water, per metre of light path, each 0..1000.
    std::array<double, 3> attenuationPerM{0.0, 0.0, 0.0};
    double maxPathM{0.0};  ///< the longest light path, m, in (0, 1000]
    /// The colour the water acts on (the target's in clear water), when
    /// narrower than the type's ranges; unset: the type's own.
    std::optional<Range> redGreen;
    std::optional<Range> blueGreen;
    bool operator==(const Water& o) const {
        return attenuationPerM == o.attenuationPerM && maxPathM == o.maxPathM && redGreen == o.redGreen &&
               blueGreen == o.blueGreen;
    }
};

/// The most brightness bands a target type may have.
inline constexpr std::size_t kMaxBrightnessBands = 16;

/// One kind of thing to find (e.g. "sample", "arm_marker").
struct TargetType {
    std::string name;  ///< unique, [A-Za-z0-9_-]+
    ColorFilterMethod filter{ColorFilterMethod::RgbRatio};
    Range redGreen{0.0, 1e9};   ///< R/G
    Range redBlue{0.0, 1e9};    ///< R/B
    Range blueGreen{0.0, 1e9};  ///< B/G
    /// R+G+B magnitude, in the units of the image's samples; unset: not checked.
    std::optional<Range> brightness;
    /// Ratio ranges by brightness (rgb_ratio only; at most 16, not
    /// overlapping). Pixels in no band use redGreen, redBlue, blueGreen.
    std::vector<BrightnessBand> brightnessBands;
    /// The site's haze (rgb_ratio without brightness bands only); unset: none.
    std::optional<Veil> veil;
    /// The site's water (rgb_ratio without brightness bands only); unset: none.
    std::optional<Water> water;
    HsvRanges hsv;              ///< used when filter == Hsv
    bool erodeRestore{false};   ///< erode, then feature-AND restore (thesis 3.3.2)
    int erodeKernelSize{3};     ///< odd, 1..31
    Range area{20.0, 1e9};      ///< feature area in pixels
    Range aspectRatio{0.0, 1e9};  ///< bounding-box width / height
    Range areaRatio{0.0, 1.0};  ///< area / bounding-box area, within [0, 1]
    SearchWindow window;        ///< where to look
    TargetShape shape{TargetShape::None};
    /// The physical size of one target of this type, mm, as measured at its
    /// range (the mean of the two views): a sphere's or disc's diameter (its
    /// fitted ellipses' major axes) when the type is round, otherwise the
    /// diameter of the circle with its silhouette's area (2 sqrt(A / pi) d / f).
    /// A stereo target outside it is not whole: larger, `merged` (touching
    /// targets seen as one, or something bigger of this colour); smaller,
    /// `ambiguous`. Unset: not checked.
    std::optional<Range> sizeMm;

    bool operator==(const TargetType& o) const {
        return name == o.name && filter == o.filter && redGreen == o.redGreen &&
               redBlue == o.redBlue && blueGreen == o.blueGreen && brightness == o.brightness &&
               brightnessBands == o.brightnessBands && veil == o.veil && water == o.water &&
               hsv == o.hsv && erodeRestore == o.erodeRestore &&
               erodeKernelSize == o.erodeKernelSize && area == o.area &&
               aspectRatio == o.aspectRatio && areaRatio == o.areaRatio && window == o.window &&
               shape == o.shape && sizeMm == o.sizeMm;
    }
};

/// All target types searched for in each image pair.
struct TargetConfig {
    std::vector<TargetType> targets;
    bool operator==(const TargetConfig& o) const { return targets == o.targets; }
};

}  // namespace avatar
