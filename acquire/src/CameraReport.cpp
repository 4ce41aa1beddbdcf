#include <avatar/acquire/CameraReport.h>

#include <avatar/common/Error.h>

#include <algorithm>

namespace avatar {

const std::vector<std::string>& cameraFeatureNames() {
    static const std::vector<std::string> names{"exposure", "shutter", "gain", "whiteBalance", "brightness", "gamma"};
    return names;
}

const FeatureReading& CameraFeatureReadback::feature(const std::string& name) const {
    const auto& names = cameraFeatureNames();
    if (std::find(names.begin(), names.end(), name) == names.end())
        throw InvalidArgument("'" + name +
                              "' is not a camera feature (one of exposure, shutter, gain, whiteBalance, brightness, "
                              "gamma)");
    for (const FeatureReading& f : features)
        if (f.name == name) return f;
    throw InvalidArgument("the readback of camera '" + cameraId + "' has no feature '" + name + "'");
}

bool BackendSurvey::ok() const {
    return std::all_of(checks.begin(), checks.end(), [](const BackendCheck& c) { return c.ok; });
}

}  // namespace avatar
