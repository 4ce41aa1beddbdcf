#pragma once
// The Scorpion stereo calibration of thesis Table 6-4 (no distortion published).

#include <avatar/config/StereoSystemConfig.h>

namespace avatar::test {

inline StereoSystemConfig scorpionCalibration() {
    StereoSystemConfig c;
    c.left.fc = {1049.13, 1050.38};
    c.left.cc = {712.28, 564.45};
    c.right.fc = {1047.20, 1048.66};
    c.right.cc = {702.74, 561.13};
    c.om = {0.002, 0.003, 0.047};
    c.translationMm = {-106.53, -2.58, 0.82};
    return c;
}

}  // namespace avatar::test
