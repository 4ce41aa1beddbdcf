#pragma once
/// @file ToolImages.h
/// One image as the stages of the pipeline see it, for the tools that tune
/// them on an image (avatar-filterstats, avatar-filtergui, avatar-lightfit):
/// raw files (docs/formats.md), 8- and 16-bit PNG/TIFF, any other 8-bit image
/// file, or one image of a recorded session; demosaiced when Bayer, and after
/// the configuration's lighting correction when the colour filter is tuned.
///
/// Error policy: avatar::IoError for a file that cannot be read,
/// avatar::FormatError for one that cannot be used (a monochrome image, one
/// channel without a Bayer pattern), avatar::InvalidArgument for samples
/// beyond the bit depth or a record or option that does not exist; each names
/// the file, session or option.

#include <avatar/common/ImageFormat.h>
#include <avatar/config/AvatarConfig.h>

#include <boost/program_options.hpp>
#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace avatar::tools {

/// An image as a stage sees it: 8- or 16-bit BGR.
struct WorkingImage {
    cv::Mat bgr;
    int bitDepth{8};          ///< significant bits of the samples
    std::string description;  ///< "raw 16-bit Bayer BG 1280x960 (L_...raw)", for the report
};

/// What a tool reads an image for: how it words refusing an image without
/// colour, and what it takes from a file's name. The tools grew these apart;
/// each keeps its own.
struct ImagePurpose {
    /// A monochrome raw file: "image F: a monochrome raw image has no <noColour>".
    const char* noColour;
    /// Monochrome session images: "session D: the images are monochrome; <needsColour>".
    const char* needsColour;
    /// A PNG named like a raw file (a session's lossless archive,
    /// docs/formats.md) gives the Bayer pattern of a 1-channel image (when
    /// none is given) and the significant bits (when no bit depth is given).
    bool layoutFromPngName;
    /// A PNG/TIFF of neither 8- nor 16-bit samples: the message names their type.
    bool sampleTypeInMessage;
};
/// As the colour filter sees the image (avatar-filterstats, avatar-filtergui).
inline constexpr ImagePurpose kForColourFilter{"colour to filter", "a colour filter needs colour", false, false};
/// As the lighting correction sees it (avatar-lightfit).
inline constexpr ImagePurpose kForLightingCorrection{"colour channels to correct",
                                                     "the lighting correction needs colour", true, true};

/// Reads @p path: a raw file named as docs/formats.md says (a Bayer mosaic is
/// demosaiced), a lossless PNG/TIFF (8- or 16-bit; 3 channels, or 1 channel
/// Bayer with @p bayer given), or any other 8-bit image file. @p bitDepth
/// overrides the significant bits of the samples (default: the raw name's,
/// else 8 or 16).
WorkingImage loadImage(const std::filesystem::path& path, const ImagePurpose& purpose,
                       std::optional<BayerPattern> bayer = std::nullopt, std::optional<int> bitDepth = std::nullopt);

/// One image of a recorded pair: the record of @p iteration (0: the first) in
/// the session directory, @p side of it, demosaiced when Bayer.
WorkingImage loadSessionImage(const std::filesystem::path& session, std::uint64_t iteration, Side side,
                              const ImagePurpose& purpose);

/// What the colour filter sees is the image after the configuration's
/// lighting correction (thesis 3.2): applies it in place when @p config asks
/// for one (the "lighting" stage with a gain or pattern); @p configDir
/// resolves its template image. Returns whether it did.
bool correctLighting(WorkingImage& image, const AvatarConfig& config, const std::filesystem::path& configDir);

/// Adds the options that name the image, in this order: --image (described
/// by @p imageHelp), --session, --iteration, --side, --bayer, --bit-depth.
void addImageOptions(boost::program_options::options_description& options, const std::string& imageHelp);

/// The image those options name: --session's record (InvalidArgument for a
/// --side other than left or right), else --image. The caller has checked
/// that exactly one of the two is given.
WorkingImage imageFromOptions(const boost::program_options::variables_map& vm, const ImagePurpose& purpose);

}  // namespace avatar::tools
