// The calibration accuracy report of docs/calibration.md: rendered
// checkerboard sets (known intrinsics with distortion and known extrinsics)
// calibrated by calibrateStereo; per parameter the error against the truth
// and that error in units of the stated standard error (a z-score: about 1
// in RMS when the standard errors are right). A plain program:
//   build/tests/bench/calibration_report [--sets N] [--views V]
#include "SampleConfigs.h"

#include <avatar/analyze/StereoCalibration.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/SceneSet.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <tuple>
#include <string>
#include <vector>

using namespace avatar;

int main(int argc, char** argv) {
    int sets = 6, views = 12;
    for (int i = 1; i + 1 < argc; ++i) {
        if (std::strcmp(argv[i], "--sets") == 0) sets = std::max(1, std::atoi(argv[i + 1]));
        if (std::strcmp(argv[i], "--views") == 0) views = std::max(3, std::atoi(argv[i + 1]));
    }
    StereoSystemConfig truth = test::scorpionCalibration();
    truth.left.kc = {-0.12, 0.08, 0.0008, -0.0005, 0.0};
    truth.right.kc = {-0.11, 0.07, -0.0006, 0.0004, 0.0};
    std::map<std::string, std::vector<double>> errors, z;
    std::map<std::string, int> strategies;
    std::vector<double> rms, epipolar;
    for (int set = 0; set < sets; ++set) {
        render::CheckerboardSpec spec;
        spec.views = views;
        spec.seed = 1000 + static_cast<std::uint64_t>(set);
        spec.squareMm = 25.0;
        render::RenderOptions options;
        const auto scenes = render::makeCheckerboardViews(spec, truth, options.sensor);
        std::vector<CalibrationPair> pairs;
        for (std::size_t i = 0; i < scenes.size(); ++i) {
            options.seed = 7000 + 100 * set + i;
            const StereoImagePair bgr = demosaic(render::render(scenes[i], truth, options).pair);
            const auto l = findBoardCorners(bgr.left(), {9, 6}, 16), r = findBoardCorners(bgr.right(), {9, 6}, 16);
            if (l && r) pairs.push_back({scenes[i].name, *l, *r});
        }
        const StereoCalibration c = calibrateStereo(pairs, {{9, 6}, 25.0}, {1280, 960});
        ++strategies[toString(c.strategy)];
        rms.push_back(c.rmsPx);
        epipolar.push_back(c.epipolarRmsPx);
        const CalibrationUncertainty& u = *c.stereo.uncertainty;
        const auto add = [&](const std::string& name, double est, double tru, double sd) {
            errors[name].push_back(est - tru);
            z[name].push_back(sd > 0 ? (est - tru) / sd : 0.0);
        };
        for (const auto& [side, e, t, s] :
             {std::tuple<std::string, const CameraIntrinsics&, const CameraIntrinsics&, const IntrinsicsUncertainty&>{
                  "left", c.stereo.left, truth.left, u.left},
              {"right", c.stereo.right, truth.right, u.right}}) {
            add(side + " fx (px)", e.fc[0], t.fc[0], s.fc[0]);
            add(side + " fy (px)", e.fc[1], t.fc[1], s.fc[1]);
            add(side + " cx (px)", e.cc[0], t.cc[0], s.cc[0]);
            add(side + " cy (px)", e.cc[1], t.cc[1], s.cc[1]);
            add(side + " k1", e.kc[0], t.kc[0], s.kc[0]);
            add(side + " k2", e.kc[1], t.kc[1], s.kc[1]);
        }
        const char* axes[] = {"x", "y", "z"};
        for (std::size_t k = 0; k < 3; ++k) {
            add(std::string("om ") + axes[k] + " (mrad)", 1e3 * c.stereo.om[k], 1e3 * truth.om[k], 1e3 * u.om[k]);
            add(std::string("T ") + axes[k] + " (mm)", c.stereo.translationMm[k], truth.translationMm[k],
                u.translationMm[k]);
        }
        std::fprintf(stderr, "set %d: %zu pairs, %s, rms %.4f px\n", set + 1, pairs.size(), toString(c.strategy), c.rmsPx);
    }
    const auto rmsOf = [](const std::vector<double>& v) {
        double s = 0;
        for (double x : v) s += x * x;
        return std::sqrt(s / v.size());
    };
    std::printf("%d sets of %d rendered 1280x960 pairs (9 x 6 inner corners, 25 mm, 0.5-1.5 m, tilts to 40 deg)\n",
                sets, views);
    std::printf("reprojection RMS %.3f px (mean), epipolar RMS %.3f px (mean); strategies:", [&] {
        double s = 0;
        for (double x : rms) s += x;
        return s / rms.size();
    }(), [&] {
        double s = 0;
        for (double x : epipolar) s += x;
        return s / epipolar.size();
    }());
    for (const auto& [name, count] : strategies) std::printf(" %s %d", name.c_str(), count);
    std::printf("\n\n| parameter | RMS error | RMS z (error / stated std) |\n| --- | ---: | ---: |\n");
    for (const auto& [name, e] : errors) std::printf("| %s | %.4g | %.2f |\n", name.c_str(), rmsOf(e), rmsOf(z[name]));
    return 0;
}
