#include <avatar/common/VisionTargets.h>

namespace avatar {

std::string targetFlagsText(std::uint32_t flags) {
    static const std::pair<std::uint32_t, const char*> kNames[] = {
        {kTargetStereo, "stereo"},   {kTargetLeftOnly, "left-only"},           {kTargetRightOnly, "right-only"},
        {kTargetAtBorder, "border"}, {kTargetShapeCorrected, "shape-corrected"},
    };
    std::string text;
    for (const auto& [bit, name] : kNames)
        if (flags & bit) text += (text.empty() ? "" : ",") + std::string(name);
    return text.empty() ? "-" : text;
}

}  // namespace avatar
