#pragma once
/// @file FilterGui.h
/// avatar-filtergui (docs/tools/avatar-filtergui.md; thesis 4.5.1): tune one
/// target type's colour filter and minimum area on one image by hand. This
/// library holds everything but the window: the slider scales, the scripted
/// assignments (--set), the analysis the view shows (the real colour filter,
/// erode and feature-AND restore and feature locator), the view itself and
/// saving the type into a configuration. main.cpp adds the HighGUI window.
///
/// Error policy: avatar::InvalidArgument names the assignment or slider at
/// fault; avatar::ConfigError a range the validator rejects; avatar::IoError
/// the configuration file that cannot be read or written.

#include "ToolImages.h"

#include <avatar/analyze/Feature.h>
#include <avatar/config/AnalysisConfig.h>
#include <avatar/config/AvatarConfig.h>
#include <avatar/config/TargetConfig.h>

#include <opencv2/core/mat.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace avatar::filtergui {

/// A range of a target type that a slider or an assignment sets.
enum class Quantity {
    RedGreen,     ///< "rg": R/G
    RedBlue,      ///< "rb": R/B
    BlueGreen,    ///< "bg": B/G
    Brightness,   ///< "brightness": R+G+B in sample units (optional in the type)
    Hue,          ///< "hue": degrees, a range with min > max wraps through 0
    Saturation,   ///< "saturation": 0..1
    Value,        ///< "value": 0..1
    Area,         ///< "area": feature area in px
    AspectRatio,  ///< "aspectRatio": box width / height
    AreaRatio     ///< "areaRatio": area / box area
};

/// The name of a quantity as --set and the status line write it ("rg", "hue", ...).
std::string nameOf(Quantity q);

/// The current [min, max] of @p q in @p type; an unset brightness reads as
/// 0 .. 3 * (2^bitDepth - 1), the whole scale.
Range rangeOf(const TargetType& type, Quantity q, int bitDepth);

/// Applies one assignment of --set to @p type:
///   rg.min=1.2, rb.max=100, bg.min=0, brightness.min=3000, hue.min=340,
///   saturation.max=1, value.min=0.2, area.min=50, aspectRatio.max=4,
///   areaRatio.min=0.3 (any quantity of nameOf(), .min or .max, a decimal number),
///   brightness=off (no brightness check), erodeRestore=true|false, erodeKernelSize=N.
/// Setting one end of an unset brightness sets the other to its end of the
/// whole scale. The hue, saturation and value of an rgb_ratio type and the
/// ratios and brightness of an hsv type are refused (they would have no
/// effect). The order of the two ends is not checked here (a later
/// assignment may fix it): call validateTargetType() after the last one.
/// Throws avatar::InvalidArgument naming @p assignment.
void applyAssignment(TargetType& type, const std::string& assignment, int bitDepth);

/// How a slider's integer positions map to values (docs/tools/avatar-filtergui.md):
/// - Ratio: 0..402. 0 is 0, 1..401 are 0.01 .. 100 on a log scale of 100
///   steps per decade (value 10^((p - 201) / 100), 3 significant digits, a
///   step of 2.3 %), 402 is open (1e9, passes x/0 too).
/// - Brightness: 0..1000, steps of 1/1000 of the whole scale 3 * (2^bitDepth - 1), rounded.
/// - Degrees: 0..360, one degree a step.
/// - Unit: 0..100, 0.01 a step.
/// - Area: 0..601. 0 is 0, 1..601 are 1 .. 10^6 px on a log scale of 100
///   steps per decade (10^((p - 1) / 100), rounded to a whole pixel below
///   1000 px, to 3 significant digits above).
enum class SliderScale { Ratio, Brightness, Degrees, Unit, Area };

/// One trackbar of the window: one end of one range.
struct Slider {
    std::string label;  ///< the trackbar's name, e.g. "rg min"
    Quantity quantity{Quantity::RedGreen};
    bool max{false};    ///< the range's max (else its min)
    SliderScale scale{SliderScale::Ratio};
    int count{0};       ///< positions 0..count
};

/// The sliders of a type: rg, rb, bg and brightness min/max for rgb_ratio;
/// hue, saturation and value min/max for hsv; then the minimum area.
std::vector<Slider> slidersFor(const TargetType& type);

/// The value of @p slider at @p position (clamped to 0..count).
double sliderValue(const Slider& slider, int position, int bitDepth);

/// The position nearest to the slider's current value in @p type (values
/// beyond the scale sit at its ends).
int sliderPosition(const Slider& slider, const TargetType& type, int bitDepth);

/// Sets the slider's end of its range to its value at @p position. A min
/// moved above the max takes the max with it, and a max moved below the min
/// the min (hue excepted: it wraps). Moving a brightness slider of a type
/// without a brightness range gives it one (the other end at its end of the scale).
void applySlider(TargetType& type, const Slider& slider, int position, int bitDepth);

/// What the view shows: the type's filter, restore and features on the image.
struct Analysis {
    cv::Mat mask;                   ///< the colour filter's mask (CV_8UC1, 0/255)
    cv::Mat kept;                   ///< after erode and feature-AND restore (the mask without)
    std::vector<Feature> features;  ///< located in the search window with the type's geometry ranges
    int passing{0};                 ///< pixels passing the filter
    int keptPixels{0};              ///< pixels left after erode and restore
    int components{0};              ///< 8-connected components in the window, whatever their geometry
};

/// Runs colorFilterMasks, erodeRestore (when the type asks for it and
/// @p analysis has the erode_restore stage) and locateFeatures (with the
/// image as intensity when the centroid is intensity_weighted), exactly as
/// the analysis stages do.
Analysis analyse(const tools::WorkingImage& image, const TargetType& type, const AnalysisConfig& analysis);

/// The colours of the view (BGR). The tints are blended half and half with
/// the image, so no tinted pixel is ever the box or cross colour.
inline const cv::Scalar kBoxColour{255, 0, 255};       ///< magenta: each feature's box
inline const cv::Scalar kCrossColour{0, 255, 0};       ///< green: each feature's centroid
inline const cv::Scalar kTintKept{255, 255, 0};        ///< cyan: passes, kept by erode-restore
inline const cv::Scalar kTintDropped{255, 0, 0};       ///< blue: passes, removed by erode-restore
inline const cv::Scalar kWindowColour{0, 165, 255};    ///< orange: the search window, when set
/// The box outline: the ring of this many pixels just outside viewBox().
inline constexpr int kFrameWidth = 2;
/// The centroid cross: two 1-pixel lines, this many pixels each side of viewPoint().
inline constexpr int kCrossArm = 6;
/// The status lines below the image.
inline constexpr int kStatusHeight = 66;

/// The default view scale: the image fits 1024 x 768 (never enlarged).
double defaultScale(cv::Size image);
/// Where image point @p p (pixel centres at integers) lies in the view:
/// round((p + 0.5) * scale - 0.5).
cv::Point viewPoint(cv::Point2d p, double scale);
/// The view pixels a box of image pixels covers: from floor(x * scale) to
/// ceil((x + width) * scale), exclusive, likewise in y.
cv::Rect viewBox(const cv::Rect& box, double scale);

/// The view: the image at @p scale (8-bit for display), the passing pixels
/// tinted, each feature's centroid cross and box, the search window when set,
/// and kStatusHeight pixels of status below: the counts, the ranges, and
/// @p message. Size: the scaled image's width by its height + kStatusHeight.
cv::Mat renderView(const tools::WorkingImage& image, const TargetType& type, const Analysis& analysis,
                   double scale, const std::string& message);

/// The counts line of the status: "sample: 5321 px pass, 5260 kept; 1 feature (of 3 components)".
std::string countsText(const TargetType& type, const Analysis& analysis);
/// The ranges line of the status: "rg 0.9..1.6  rb 2.5..100  bg 0..0.45  brightness any  area >= 150".
std::string rangesText(const TargetType& type);

/// Saves @p type into a configuration: into @p destination's own
/// configuration when that file exists, else into @p source's (read now, so
/// edits made since are kept), replacing the type of its name (or appending
/// it) and keeping everything else; written atomically by writeConfigFile().
/// A relative lighting template path is made absolute when the destination
/// is in another directory than the configuration it came from. Returns
/// whether a type was replaced (false: appended).
bool saveType(const TargetType& type, const std::filesystem::path& source, const std::filesystem::path& destination);

}  // namespace avatar::filtergui
