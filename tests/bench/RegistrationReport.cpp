// The registration accuracy report of docs/calibration.md: median and p95
// rotation and translation error of the closed form (default), the thesis's
// iterative algorithm (Figure 3-1) and the robust solver, on synthetic point
// sets (tests/support/RegistrationScenes.h). A plain program, not a timed
// benchmark:  build/tests/bench/registration_report [--trials N]
#include "RegistrationScenes.h"

#include <avatar/common/Error.h>
#include <avatar/common/Registration.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

using namespace avatar;

namespace {

struct Stats {
    double medianDeg{0}, p95Deg{0}, medianMm{0}, p95Mm{0};
    int wrong{0};     ///< rotation error above 5 degrees: a wrong solution
    int refused{0};   ///< the solver threw (a layout that determines no rotation)
};

double quantile(std::vector<double> v, double q) {
    if (v.empty()) return std::nan("");
    std::sort(v.begin(), v.end());
    return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, std::floor(q * v.size())))];
}

using Solver = std::function<RigidTransform(const test::PointSet&, std::uint64_t)>;

Stats run(const test::PointSetSpec& spec, const Solver& solve, int trials) {
    std::vector<double> deg, mm;
    Stats s;
    for (int t = 1; t <= trials; ++t) {
        const test::PointSet set = test::drawPointSet(spec, static_cast<std::uint64_t>(t) * 7919u);
        try {
            const RigidTransform r = solve(set, static_cast<std::uint64_t>(t));
            const double e = rotationAngleBetween(rotationMatrix(r), rotationMatrix(set.baseTVision)) * 180.0 / M_PI;
            deg.push_back(e);
            mm.push_back(cv::norm(translationVector(r) - translationVector(set.baseTVision)));
            s.wrong += e > 5.0;
        } catch (const InvalidArgument&) {
            ++s.refused;
        }
    }
    s.medianDeg = quantile(deg, 0.5);
    s.p95Deg = quantile(deg, 0.95);
    s.medianMm = quantile(mm, 0.5);
    s.p95Mm = quantile(mm, 0.95);
    return s;
}

void row(const std::string& setName, const char* solver, const Stats& s, int trials) {
    std::printf("| %-34s | %-11s | %8.4f | %8.4f | %8.3f | %8.3f | %5d | %5d |\n", setName.c_str(), solver, s.medianDeg,
                s.p95Deg, s.medianMm, s.p95Mm, s.wrong, s.refused);
    (void)trials;
}

}  // namespace

int main(int argc, char** argv) {
    int trials = 300;
    for (int i = 1; i + 1 < argc; ++i)
        if (std::strcmp(argv[i], "--trials") == 0) trials = std::max(10, std::atoi(argv[i + 1]));
    const Solver closed = [](const test::PointSet& s, std::uint64_t) { return registerClosedForm(s.vision, s.base); };
    const Solver iterative = [](const test::PointSet& s, std::uint64_t) { return registerIterative(s.vision, s.base); };
    const Solver robust = [](const test::PointSet& s, std::uint64_t seed) {
        RobustRegistrationOptions o;
        o.seed = seed;
        return registerRobust(s.vision, s.base, o).baseTVision;
    };
    // avatar-register's default: outlier rejection, the closed form on the
    // inliers, and a refusal when the rotation is more uncertain than 1 degree.
    const Solver standard = [](const test::PointSet& s, std::uint64_t seed) {
        RegistrationOptions o;
        o.robust.seed = seed;
        return registerPoints(s.vision, s.base, o).baseTVision;
    };
    std::printf("%d trials per row; points in a 1 m cube 0.3..1.3 m in front of the cameras, per-axis Gaussian\n"
                "noise in both frames; rotation about a random axis. 'wrong': rotation error above 5 degrees;\n"
                "'refused': the solver refused the layout (InvalidArgument).\n\n",
                trials);
    std::printf("| set | solver | rot median (deg) | rot p95 (deg) | t median (mm) | t p95 (mm) | wrong | refused |\n");
    std::printf("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n");
    struct Rotation {
        const char* name;
        double rad;
    };
    for (const Rotation& rotation : {Rotation{"small (3 deg)", 0.05}, Rotation{"large (86 deg)", 1.5},
                                     Rotation{"near 180 deg", M_PI - 0.01}}) {
        for (const int n : {7, 20, 50}) {
            for (const double noise : {0.0, 1.0, 5.0}) {
                test::PointSetSpec spec;
                spec.points = n;
                spec.noiseMm = noise;
                spec.rotationRad = rotation.rad;
                char name[96];
                std::snprintf(name, sizeof name, "n %d, noise %g mm, %s", n, noise, rotation.name);
                row(name, "closed form", run(spec, closed, trials), trials);
                row(name, "iterative", run(spec, iterative, trials), trials);
            }
        }
    }
    for (const int n : {7, 20, 50}) {
        test::PointSetSpec spec;
        spec.points = n;
        spec.noiseMm = 1.0;
        spec.rotationRad = 1.5;
        char name[96];
        std::snprintf(name, sizeof name, "n %d, 1 mm, 86 deg, no outliers", n);
        row(name, "closed form", run(spec, closed, trials), trials);
        row(name, "default", run(spec, standard, trials), trials);
        spec.outlierFraction = 0.2;
        std::snprintf(name, sizeof name, "n %d, 1 mm, 86 deg, 20%% outliers", n);
        row(name, "closed form", run(spec, closed, trials), trials);
        row(name, "robust", run(spec, robust, trials), trials);
        row(name, "default", run(spec, standard, trials), trials);
    }
    for (const double thickness : {50.0, 5.0, 0.5}) {
        test::PointSetSpec spec;
        spec.points = 20;
        spec.noiseMm = 1.0;
        spec.rotationRad = 1.5;
        spec.lineThicknessMm = thickness;
        char name[96];
        std::snprintf(name, sizeof name, "near a line (+-%g mm), n 20, 1 mm", thickness);
        row(name, "closed form", run(spec, closed, trials), trials);
        row(name, "iterative", run(spec, iterative, trials), trials);
        row(name, "default", run(spec, standard, trials), trials);
    }
    {
        test::PointSetSpec spec;
        spec.points = 20;
        spec.noiseMm = 1.0;
        spec.rotationRad = 1.5;
        spec.lineThicknessMm = -1.0;
        row("one plane, n 20, 1 mm", "closed form", run(spec, closed, trials), trials);
        row("one plane, n 20, 1 mm", "iterative", run(spec, iterative, trials), trials);
        row("one plane, n 20, 1 mm", "default", run(spec, standard, trials), trials);
    }
    return 0;
}
