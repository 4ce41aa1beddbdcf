#pragma once
// The shipped sample configuration as the tests use it. data/config/scorpion.xml
// is the one source of the Scorpion calibration (thesis Table 6-4; no
// distortion published); nothing here types its numbers again.

#include <avatar/config/ConfigXml.h>

#include <string>

namespace avatar::test {

/// data/config/scorpion.xml (read and validated).
inline AvatarConfig scorpionSample() { return readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml"); }

/// Its stereo calibration, without the sample's example registration.
inline StereoSystemConfig scorpionCalibration() {
    StereoSystemConfig c = scorpionSample().stereo;
    c.baseTVision.reset();
    return c;
}

/// The same cameras binned to 640x480: focal lengths and principal points halved.
inline StereoSystemConfig halfScorpion() {
    StereoSystemConfig c = scorpionCalibration();
    for (CameraIntrinsics* camera : {&c.left, &c.right}) {
        camera->fc = {camera->fc[0] / 2, camera->fc[1] / 2};
        camera->cc = {camera->cc[0] / 2, camera->cc[1] / 2};
    }
    return c;
}

}  // namespace avatar::test
