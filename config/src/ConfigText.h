#pragma once
/// @file ConfigText.h
/// Internal: the text forms shared by the reader, the writer and the validator:
/// numbers and the words that name enumerators.

#include <avatar/common/ImageFormat.h>
#include <avatar/common/internal/Text.h>
#include <avatar/config/AnalysisConfig.h>
#include <avatar/config/MatchConfig.h>
#include <avatar/config/ServoConfig.h>
#include <avatar/config/TargetConfig.h>

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace avatar::config_internal {

/// The shortest decimal text that reads back (std::from_chars) to exactly @p value,
/// e.g. "1049.13", "1e+09", "-0". Non-finite values give "inf", "-inf" or "nan".
using text::formatDouble;

/// The document's words for the enumerators of @p Enum: a table, the list for
/// messages ("a, b or c") and the C++ type name for messages about values
/// outside the enum.
template <typename Enum>
struct EnumWords;

template <>
struct EnumWords<BayerPattern> {
    static constexpr std::array<std::pair<BayerPattern, std::string_view>, 4> table{{
        {BayerPattern::BG, "BG"}, {BayerPattern::GB, "GB"}, {BayerPattern::RG, "RG"}, {BayerPattern::GR, "GR"}}};
    static constexpr const char* list = "BG, GB, RG or GR";
    static constexpr const char* type = "BayerPattern";
};

template <>
struct EnumWords<MatchMethod> {
    static constexpr std::array<std::pair<MatchMethod, std::string_view>, 3> table{{
        {MatchMethod::Shape, "shape"}, {MatchMethod::EpipolarBox, "epipolar_box"},
        {MatchMethod::EpipolarLine, "epipolar_line"}}};
    static constexpr const char* list = "shape, epipolar_box or epipolar_line";
    static constexpr const char* type = "MatchMethod";
};

template <>
struct EnumWords<RepeatMatchPolicy> {
    static constexpr std::array<std::pair<RepeatMatchPolicy, std::string_view>, 2> table{{
        {RepeatMatchPolicy::Void, "void"}, {RepeatMatchPolicy::Reassign, "reassign"}}};
    static constexpr const char* list = "void or reassign";
    static constexpr const char* type = "RepeatMatchPolicy";
};

template <>
struct EnumWords<ColorFilterMethod> {
    static constexpr std::array<std::pair<ColorFilterMethod, std::string_view>, 2> table{{
        {ColorFilterMethod::RgbRatio, "rgb_ratio"}, {ColorFilterMethod::Hsv, "hsv"}}};
    static constexpr const char* list = "rgb_ratio or hsv";
    static constexpr const char* type = "ColorFilterMethod";
};

template <>
struct EnumWords<TargetShape> {
    // "unknown" is the name version 1 of the schema gave "none"; still read.
    static constexpr std::array<std::pair<TargetShape, std::string_view>, 5> table{{
        {TargetShape::None, "none"}, {TargetShape::Sphere, "sphere"}, {TargetShape::Disc, "disc"},
        {TargetShape::Composite, "composite"}, {TargetShape::None, "unknown"}}};
    static constexpr const char* list = "none, sphere, disc or composite";
    static constexpr const char* type = "TargetShape";
};

template <>
struct EnumWords<DemosaicAlgorithm> {
    static constexpr std::array<std::pair<DemosaicAlgorithm, std::string_view>, 2> table{{
        {DemosaicAlgorithm::Bilinear, "bilinear"}, {DemosaicAlgorithm::EdgeAware, "edge_aware"}}};
    static constexpr const char* list = "bilinear or edge_aware";
    static constexpr const char* type = "DemosaicAlgorithm";
};

template <>
struct EnumWords<CentroidMode> {
    static constexpr std::array<std::pair<CentroidMode, std::string_view>, 3> table{{
        {CentroidMode::Pixel, "pixel"}, {CentroidMode::IntensityWeighted, "intensity_weighted"},
        {CentroidMode::Coverage, "coverage"}}};
    static constexpr const char* list = "pixel, intensity_weighted or coverage";
    static constexpr const char* type = "CentroidMode";
};

template <>
struct EnumWords<TriangulationMode> {
    static constexpr std::array<std::pair<TriangulationMode, std::string_view>, 1> table{{
        {TriangulationMode::Centroid, "centroid"}}};
    static constexpr const char* list = "centroid (nine_points was removed: docs/accuracy.md)";
    static constexpr const char* type = "TriangulationMode";
};

template <>
struct EnumWords<ServoMode> {
    static constexpr std::array<std::pair<ServoMode, std::string_view>, 3> table{{
        {ServoMode::Servo, "servo"}, {ServoMode::DeadReckoning, "dead_reckoning"}, {ServoMode::Hybrid, "hybrid"}}};
    static constexpr const char* list = "servo, dead_reckoning or hybrid";
    static constexpr const char* type = "ServoMode";
};

template <>
struct EnumWords<ServoFilter> {
    static constexpr std::array<std::pair<ServoFilter, std::string_view>, 2> table{{
        {ServoFilter::None, "none"}, {ServoFilter::Kalman, "kalman"}}};
    static constexpr const char* list = "none or kalman";
    static constexpr const char* type = "ServoFilter";
};

/// The word for @p value; std::nullopt for a value outside the enum.
template <typename Enum>
std::optional<std::string_view> enumWord(Enum value) {
    for (const auto& [e, word] : EnumWords<Enum>::table) {
        if (e == value) {
            return word;
        }
    }
    return std::nullopt;
}

/// The enumerator named by @p word (case-sensitive); std::nullopt if none is.
template <typename Enum>
std::optional<Enum> parseEnumWord(std::string_view word) {
    for (const auto& [e, w] : EnumWords<Enum>::table) {
        if (w == word) {
            return e;
        }
    }
    return std::nullopt;
}

}  // namespace avatar::config_internal
