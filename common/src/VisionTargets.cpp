#include <avatar/common/VisionTargets.h>

#include <utility>

namespace avatar {

std::string targetFlagsText(std::uint32_t flags) {
    static const std::pair<std::uint32_t, const char*> kNames[] = {
        {kTargetStereo, "stereo"},
        {kTargetLeftOnly, "left-only"},
        {kTargetRightOnly, "right-only"},
        {kTargetAtBorder, "border"},
        {kTargetShapeCorrected, "shape-corrected"},
        {kTargetWhole, "whole"},
        {kTargetCut, "cut"},
        {kTargetOccludedLeft, "occluded-left"},
        {kTargetOccludedRight, "occluded-right"},
        {kTargetMerged, "merged"},
        {kTargetAmbiguous, "ambiguous"},
        {kTargetPoorVisibility, "poor-visibility"},
    };
    std::string text;
    const auto add = [&](const std::string& name) { text += (text.empty() ? "" : ",") + name; };
    for (const auto& [bit, name] : kNames)
        if (flags & bit) add(name);
    for (int bit = 0; bit < 32; ++bit)
        if ((flags >> bit & 1u) && !(kTargetFlagsAll >> bit & 1u)) add("bit" + std::to_string(bit));
    return text.empty() ? "-" : text;
}

std::string_view toString(ShapeModel model) {
    switch (model) {
        case ShapeModel::None: return "none";
        case ShapeModel::Sphere: return "sphere";
        case ShapeModel::Disc: return "disc";
        case ShapeModel::Composite: return "composite";
    }
    return "none";
}

}  // namespace avatar
