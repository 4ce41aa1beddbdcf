#include <avatar/render/SceneSet.h>

#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>

#include <cmath>
#include <cstdio>
#include <optional>
#include <utility>
#include <random>

namespace avatar::render {

namespace {

void require(bool ok, const std::string& field, const std::string& problem) {
    if (!ok) throw InvalidArgument(field + ": " + problem);
}

std::uint64_t sceneSeed(std::uint64_t seed, std::uint64_t index) {
    std::uint64_t x = seed * 0x9e3779b97f4a7c15ULL + index + 1;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

class Random {
public:
    explicit Random(std::uint64_t seed) : engine_(seed) {}
    double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(engine_); }
    int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(engine_); }
    bool chance(double p) { return uniform(0.0, 1.0) < p; }

private:
    std::mt19937_64 engine_;
};

/// Centre and radius (px) of the disc that holds a ball's silhouette in a
/// camera (generous: 1.2 x the on-axis radius + 1 px); nullopt behind it.
std::optional<std::pair<cv::Point2d, double>> imageDisc(const CameraIntrinsics& k, const cv::Vec3d& centre,
                                                        double radius) {
    if (centre[2] <= radius) return std::nullopt;
    const auto px = projectPoint(k, cv::Point3d(centre));
    if (!px) return std::nullopt;
    return std::make_pair(*px, 1.2 * k.fc[0] * radius / centre[2] + 1.0);
}

/// Unit ray of the left camera through a pixel.
cv::Vec3d rayThrough(const CameraIntrinsics& k, double u, double v) {
    const cv::Point2d xn = normalizePixelExact(k, {u, v}).value_or(pixelToNormalized(k, {u, v}));
    const cv::Vec3d d(xn.x, xn.y, 1.0);
    return d / cv::norm(d);
}

}  // namespace

void SceneSetSpec::validate() const {
    require(count >= 1 && count <= 100000, "SceneSetSpec.count", "expected 1..100000, got " + std::to_string(count));
    require(minTargets >= 1 && maxTargets >= minTargets && maxTargets <= 32, "SceneSetSpec.minTargets/maxTargets",
            "expected 1 <= min <= max <= 32, got " + std::to_string(minTargets) + ".." + std::to_string(maxTargets));
    require(minRangeMm > 0.0 && maxRangeMm >= minRangeMm, "SceneSetSpec.minRangeMm/maxRangeMm",
            "expected 0 < min <= max");
    require(minRadiusMm > 0.0 && maxRadiusMm >= minRadiusMm, "SceneSetSpec.minRadiusMm/maxRadiusMm",
            "expected 0 < min <= max");
    require(!colours.empty(), "SceneSetSpec.colours", "at least one colour is needed");
    for (double p : {nearBorderProbability, occludedInOneCameraProbability, touchingProbability, distractorProbability,
                     targetOcclusionProbability, waterProbability, darkProbability, mixedColourProbability,
                     siltProbability})
        require(p >= 0.0 && p <= 1.0, "SceneSetSpec probabilities", "expected values in [0, 1]");
}

void CheckerboardSpec::validate() const {
    require(views >= 1 && views <= 10000, "CheckerboardSpec.views", "expected 1..10000, got " + std::to_string(views));
    require(squaresX >= 3 && squaresY >= 3, "CheckerboardSpec.squaresX/squaresY", "expected at least 3 x 3 squares");
    require(squareMm > 0.0, "CheckerboardSpec.squareMm", "expected > 0");
    require(minRangeMm > 0.0 && maxRangeMm >= minRangeMm, "CheckerboardSpec.minRangeMm/maxRangeMm",
            "expected 0 < min <= max");
    require(maxTiltDeg >= 0.0 && maxTiltDeg < 80.0, "CheckerboardSpec.maxTiltDeg", "expected 0..80");
}

namespace {

/// The variations of SceneSetSpec drawn from their own stream (see there).
void addVariations(const SceneSetSpec& spec, const StereoSystemConfig& stereo, const SensorFormat& sensor, int index,
                   Scene& s) {
    Random rng(sceneSeed(spec.seed ^ 0x5eedfaceULL, static_cast<std::uint64_t>(index)));
    const double w = sensor.width, h = sensor.height;
    const RigidTransform rTl = rightTLeft(stereo);
    const cv::Point3d rc = transformPoint(inverse(rTl), {0, 0, 0});
    const cv::Vec3d rightCentre(rc.x, rc.y, rc.z);
    const auto colour = [&] {
        return spec.colours[static_cast<std::size_t>(rng.integer(0, static_cast<int>(spec.colours.size()) - 1))];
    };
    const auto nextName = [&] { return "t" + std::to_string(s.targets.size() + 1); };

    if (rng.chance(spec.mixedColourProbability) && spec.colours.size() >= 2) {
        const int a = rng.integer(0, static_cast<int>(spec.colours.size()) - 1);
        int b = rng.integer(0, static_cast<int>(spec.colours.size()) - 2);
        if (b >= a) ++b;
        const double t = rng.uniform(0.35, 0.65);
        TargetSpec m;
        m.name = "mix_" + nextName();
        const TargetColour& ca = spec.colours[static_cast<std::size_t>(a)];
        const TargetColour& cb = spec.colours[static_cast<std::size_t>(b)];
        m.type = t < 0.5 ? ca.name : cb.name;
        for (std::size_t c = 0; c < 3; ++c) m.albedo[c] = (1.0 - t) * ca.albedo[c] + t * cb.albedo[c];
        m.shape = rng.chance(0.5) ? Shape::Sphere : Shape::Disc;
        m.radiusMm = rng.uniform(spec.minRadiusMm, spec.maxRadiusMm);
        m.centreMm = rayThrough(stereo.left, rng.uniform(100.0, w - 100.0), rng.uniform(100.0, h - 100.0)) *
                     rng.uniform(spec.minRangeMm, spec.maxRangeMm);
        s.targets.push_back(m);
    }

    if (rng.chance(spec.targetOcclusionProbability) && !s.targets.empty()) {
        // B in front of A, overlapping A in one camera and apart from it in
        // the other; a few tries, or none at all.
        const TargetSpec a = s.targets[static_cast<std::size_t>(rng.integer(0, static_cast<int>(s.targets.size()) - 1))];
        for (int attempt = 0; attempt < 40; ++attempt) {
            const bool inRight = rng.chance(0.5);
            const cv::Vec3d camera = inRight ? rightCentre : cv::Vec3d(0, 0, 0);
            const cv::Vec3d toA = a.centreMm - camera;
            TargetSpec b;
            b.name = nextName();
            const TargetColour c = rng.chance(0.5) ? TargetColour{a.type, a.albedo} : colour();
            b.type = c.name;
            b.albedo = c.albedo;
            b.shape = rng.chance(0.5) ? Shape::Sphere : Shape::Disc;
            b.radiusMm = rng.uniform(spec.minRadiusMm, spec.maxRadiusMm) * 0.8;
            const double f = rng.uniform(0.55, 0.85);
            const double az = rng.uniform(0.0, 2.0 * M_PI);
            cv::Vec3d side = toA.cross(cv::Vec3d(std::cos(az), std::sin(az), 0.0));
            side /= cv::norm(side);
            // Overlap by 20-60 % of A's apparent radius in that camera.
            const double ra = a.radiusMm / cv::norm(toA), rb = b.radiusMm / (f * cv::norm(toA));
            const double offset = (ra + rb - rng.uniform(0.2, 0.6) * ra) * f * cv::norm(toA);
            b.centreMm = camera + toA * f + side * offset;
            if (cv::norm(b.centreMm) < spec.minRangeMm * 0.6) continue;
            const auto inView = [&](const CameraIntrinsics& k, const cv::Vec3d& centre, double r, bool rightCamera) {
                const cv::Point3d p = rightCamera ? transformPoint(rTl, cv::Point3d(centre)) : cv::Point3d(centre);
                return imageDisc(k, cv::Vec3d(p.x, p.y, p.z), r);
            };
            const auto aL = inView(stereo.left, a.centreMm, a.radiusMm, false), bL = inView(stereo.left, b.centreMm, b.radiusMm, false);
            const auto aR = inView(stereo.right, a.centreMm, a.radiusMm, true), bR = inView(stereo.right, b.centreMm, b.radiusMm, true);
            if (!aL || !bL || !aR || !bR) continue;
            const auto inside = [&](const std::pair<cv::Point2d, double>& d) {
                return d.first.x > d.second && d.first.y > d.second && d.first.x < w - d.second && d.first.y < h - d.second;
            };
            if (!inside(*bL) || !inside(*bR)) continue;
            const double gapL = cv::norm(aL->first - bL->first) - aL->second - bL->second;
            const double gapR = cv::norm(aR->first - bR->first) - aR->second - bR->second;
            const double gapOther = inRight ? gapL : gapR, gapThis = inRight ? gapR : gapL;
            if (gapThis < -3.0 && gapOther > 3.0) {
                s.targets.push_back(b);
                break;
            }
        }
    }

    if (rng.chance(spec.waterProbability)) {
        Lighting& l = s.lighting;
        l.attenuationPerM = {rng.uniform(0.05, 0.3), rng.uniform(0.01, 0.05), rng.uniform(0.02, 0.12)};
        l.ambient[0] *= rng.uniform(0.4, 0.8);
        l.ambient[2] *= rng.uniform(0.85, 1.0);
        l.background = {0.0, 0.02, 0.03};
    }
    if (rng.chance(spec.darkProbability)) {
        s.lighting.darknessFactor = rng.uniform(0.1, 0.25);
        s.sensor.readNoiseDn = rng.uniform(20.0, 40.0);
    }
    if (rng.chance(spec.siltProbability)) {
        const int particles = rng.integer(60, 200);
        for (int k = 0; k < particles; ++k) {
            Occluder o;
            o.name = "silt" + std::to_string(k + 1);
            o.radiusMm = rng.uniform(0.7, 3.0);
            o.centreMm = rayThrough(stereo.left, rng.uniform(0.0, w), rng.uniform(0.0, h)) *
                         rng.uniform(150.0, spec.maxRangeMm);
            const double g = rng.uniform(0.6, 0.9);
            o.albedo = {g, g, g * 0.95};
            s.occluders.push_back(o);
        }
        s.lighting.turbidityPerM = rng.uniform(0.1, 0.5);
        const double b = rng.uniform(0.03, 0.12);
        s.lighting.backscatter = {0.7 * b, b, b};
    }
}

}  // namespace

std::vector<Scene> makeSceneSet(const SceneSetSpec& spec, const StereoSystemConfig& stereo,
                                const SensorFormat& sensor, const std::string& prefix) {
    spec.validate();
    const double w = sensor.width, h = sensor.height;
    const RigidTransform rTl = rightTLeft(stereo);
    const RigidTransform lTr = inverse(rTl);
    const cv::Point3d rightCentre = transformPoint(lTr, {0, 0, 0});
    std::vector<Scene> scenes;
    for (int index = 0; index < spec.count; ++index) {
        Random rng(sceneSeed(spec.seed, static_cast<std::uint64_t>(index)));
        Scene s;
        char name[64];
        std::snprintf(name, sizeof name, "%s%04d", prefix.c_str(), index);
        s.name = name;
        s.seabed.tiltDeg = rng.uniform(0.0, 35.0);
        // Behind every target even at the bottom of the image (normalised y up to ~0.5).
        s.seabed.distanceMm = (spec.maxRangeMm + 300.0) * (1.0 + std::tan(s.seabed.tiltDeg * M_PI / 180.0) * 0.55);
        s.seabed.textureSeed = static_cast<std::uint64_t>(rng.integer(1, 1 << 30));
        s.seabed.textureContrast = rng.uniform(0.1, 0.4);
        const double ambient = rng.uniform(0.2, 0.4);
        const double lamp = rng.uniform(0.35, 0.6);
        s.lighting.ambient = {ambient, ambient, ambient};
        s.lighting.lightIntensity = {lamp, lamp, lamp};
        s.sensor.readNoiseDn = rng.uniform(0.0, 40.0);
        s.sensor.shotNoise = true;

        auto randomTarget = [&](int k, double u, double v) {
            TargetSpec t;
            t.name = "t" + std::to_string(k + 1);
            const TargetColour& colour = spec.colours[static_cast<std::size_t>(rng.integer(0, static_cast<int>(spec.colours.size()) - 1))];
            t.type = colour.name;
            t.albedo = colour.albedo;
            const int shape = rng.integer(0, 2);
            t.shape = shape == 0 ? Shape::Sphere : shape == 1 ? Shape::Disc : Shape::Duck;
            t.radiusMm = rng.uniform(spec.minRadiusMm, spec.maxRadiusMm);
            const double range = rng.uniform(spec.minRangeMm, spec.maxRangeMm);
            t.centreMm = rayThrough(stereo.left, u, v) * range;
            if (t.shape == Shape::Disc) {
                // Facing the camera, tilted by up to 35 degrees.
                const double tilt = rng.uniform(0.0, 35.0) * M_PI / 180.0, az = rng.uniform(0.0, 2.0 * M_PI);
                t.normal = {std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az), -std::cos(tilt)};
            }
            if (t.shape == Shape::Duck) t.om = {0.0, rng.uniform(-M_PI, M_PI), 0.0};
            return t;
        };

        const int n = rng.integer(spec.minTargets, spec.maxTargets);
        for (int k = 0; k < n; ++k)
            s.targets.push_back(randomTarget(k, rng.uniform(60.0, w - 60.0), rng.uniform(60.0, h - 60.0)));
        if (rng.chance(spec.nearBorderProbability)) {
            const int side = rng.integer(0, 3);
            const double off = rng.uniform(-10.0, 25.0);
            const double u = side == 0 ? off : side == 1 ? w - 1.0 - off : rng.uniform(0.0, w - 1.0);
            const double v = side == 2 ? off : side == 3 ? h - 1.0 - off : rng.uniform(0.0, h - 1.0);
            s.targets.push_back(randomTarget(static_cast<int>(s.targets.size()), u, v));
        }
        if (rng.chance(spec.touchingProbability)) {
            TargetSpec a = randomTarget(static_cast<int>(s.targets.size()), rng.uniform(150.0, w - 150.0),
                                        rng.uniform(150.0, h - 150.0));
            a.shape = Shape::Sphere;
            TargetSpec b = a;
            b.name = "t" + std::to_string(s.targets.size() + 2);
            b.radiusMm = rng.uniform(spec.minRadiusMm, spec.maxRadiusMm);
            if (rng.chance(0.5)) {  // another colour half of the time
                const TargetColour& c = spec.colours[static_cast<std::size_t>(rng.integer(0, static_cast<int>(spec.colours.size()) - 1))];
                b.type = c.name;
                b.albedo = c.albedo;
            }
            // Side by side, touching, perpendicular to the viewing ray.
            const cv::Vec3d ray = a.centreMm / cv::norm(a.centreMm);
            const double az = rng.uniform(0.0, 2.0 * M_PI);
            cv::Vec3d side = cv::Vec3d(std::cos(az), std::sin(az), 0.0);
            side -= ray * side.dot(ray);
            side /= cv::norm(side);
            b.centreMm = a.centreMm + side * (a.radiusMm + b.radiusMm);
            s.targets.push_back(a);
            s.targets.push_back(b);
        }
        if (rng.chance(spec.occludedInOneCameraProbability) && !s.targets.empty()) {
            // A small sphere on the line from one camera to a target, at 35% of the way:
            // it covers part of that target in that camera; the other camera, a baseline
            // away, looks past it.
            const TargetSpec& t = s.targets[static_cast<std::size_t>(rng.integer(0, static_cast<int>(s.targets.size()) - 1))];
            const bool fromRight = rng.chance(0.5);
            const cv::Vec3d camera = fromRight ? cv::Vec3d(rightCentre.x, rightCentre.y, rightCentre.z) : cv::Vec3d(0, 0, 0);
            const cv::Vec3d toTarget = t.centreMm - camera;
            const double f = 0.35;
            cv::Vec3d side = toTarget.cross(cv::Vec3d(0, 1, 0));
            side /= cv::norm(side);
            Occluder o;
            o.name = std::string("occluder_") + (fromRight ? "right_" : "left_") + t.name;
            o.radiusMm = 0.6 * t.radiusMm * f;
            o.centreMm = camera + toTarget * f + side * (0.5 * t.radiusMm * f);
            o.albedo = {0.35, 0.35, 0.35};
            s.occluders.push_back(o);
        }
        if (rng.chance(spec.distractorProbability)) {
            // Almost a target colour, but a box and not a target.
            const TargetColour& c = spec.colours[static_cast<std::size_t>(rng.integer(0, static_cast<int>(spec.colours.size()) - 1))];
            Occluder o;
            o.name = "distractor_" + c.name;
            o.shape = Shape::Box;
            for (std::size_t i = 0; i < 3; ++i)
                o.albedo[i] = std::clamp(c.albedo[i] * rng.uniform(0.85, 1.15), 0.0, 1.0);
            o.halfSizeMm = {rng.uniform(15.0, 40.0), rng.uniform(5.0, 20.0), rng.uniform(15.0, 40.0)};
            o.om = {rng.uniform(-0.5, 0.5), rng.uniform(-M_PI, M_PI), 0.0};
            o.centreMm = rayThrough(stereo.left, rng.uniform(60.0, w - 60.0), rng.uniform(60.0, h - 60.0)) *
                         rng.uniform(spec.minRangeMm, spec.maxRangeMm);
            s.occluders.push_back(o);
        }
        const int rocks = rng.integer(0, 2);
        for (int k = 0; k < rocks; ++k) {
            Occluder o;
            o.name = "rock" + std::to_string(k + 1);
            o.radiusMm = rng.uniform(30.0, 80.0);
            o.centreMm = rayThrough(stereo.left, rng.uniform(0.0, w), rng.uniform(0.0, h)) *
                         rng.uniform(spec.minRangeMm, spec.maxRangeMm + 300.0);
            const double grey = rng.uniform(0.25, 0.5);
            o.albedo = {grey, grey * 0.95, grey * 0.9};
            s.occluders.push_back(o);
        }
        addVariations(spec, stereo, sensor, index, s);
        validateScene(s);
        scenes.push_back(std::move(s));
    }
    return scenes;
}

std::vector<Scene> makeCheckerboardViews(const CheckerboardSpec& spec, const StereoSystemConfig& stereo,
                                         const SensorFormat& sensor) {
    spec.validate();
    const RigidTransform rTl = rightTLeft(stereo);
    std::vector<Scene> scenes;
    for (int index = 0; index < spec.views; ++index) {
        Random rng(sceneSeed(spec.seed ^ 0xc0ffee, static_cast<std::uint64_t>(index)));
        Checkerboard b;
        b.squaresX = spec.squaresX;
        b.squaresY = spec.squaresY;
        b.squareMm = spec.squareMm;
        const double m = (1.0 + b.marginSquares) * b.squareMm;
        const double xMax = (b.squaresX - 1) * b.squareMm + m, yMax = (b.squaresY - 1) * b.squareMm + m;
        const std::array<cv::Point3d, 4> outline{cv::Point3d(-m, -m, 0), cv::Point3d(xMax, -m, 0),
                                                 cv::Point3d(-m, yMax, 0), cv::Point3d(xMax, yMax, 0)};
        bool found = false;
        for (int attempt = 0; attempt < 2000 && !found; ++attempt) {
            // Tilt the board normal (board z is -camera z when untilted) and roll it.
            const double tilt = rng.uniform(0.0, spec.maxTiltDeg) * M_PI / 180.0;
            const double az = rng.uniform(0.0, 2.0 * M_PI);
            const cv::Matx33d tiltR = rodrigues({tilt * std::cos(az), tilt * std::sin(az), 0.0});
            const cv::Matx33d roll = rodrigues({0.0, 0.0, rng.uniform(-0.6, 0.6)});
            const cv::Matx33d r = tiltR * roll;
            const double range = rng.uniform(spec.minRangeMm, spec.maxRangeMm);
            const cv::Vec3d centre = rayThrough(stereo.left, rng.uniform(0.3, 0.7) * sensor.width,
                                                rng.uniform(0.3, 0.7) * sensor.height) * range;
            const cv::Vec3d half(0.5 * (xMax - m), 0.5 * (yMax - m), 0.0);
            const cv::Vec3d position = centre - r * half;
            b.om = rodriguesVector(r);
            b.positionMm = position;
            const RigidTransform leftTBoard = makeRigidTransform(r, position);
            found = true;
            for (const cv::Point3d& corner : outline) {
                const cv::Point3d pl = transformPoint(leftTBoard, corner);
                for (const auto& px : {projectPoint(stereo.left, pl), projectPoint(stereo.right, transformPoint(rTl, pl))}) {
                    if (!px || px->x < spec.marginPx || px->y < spec.marginPx ||
                        px->x > sensor.width - 1 - spec.marginPx || px->y > sensor.height - 1 - spec.marginPx)
                        found = false;
                }
            }
        }
        if (!found)
            throw InvalidArgument("makeCheckerboardViews: no pose of a " + std::to_string(spec.squaresX) + "x" +
                                  std::to_string(spec.squaresY) + " board of " + std::to_string(spec.squareMm) +
                                  " mm squares fits both images between " + std::to_string(spec.minRangeMm) +
                                  " and " + std::to_string(spec.maxRangeMm) + " mm");
        Scene s;
        char name[64];
        std::snprintf(name, sizeof name, "checkerboard%04d", index);
        s.name = name;
        s.seabed.distanceMm = spec.maxRangeMm * 2.5 + 1000.0;
        s.seabed.textureContrast = 0.2;
        s.lighting.ambient = {0.5, 0.5, 0.5};
        s.lighting.lightIntensity = {0.4, 0.4, 0.4};
        s.sensor.readNoiseDn = 0.0;
        s.checkerboard = b;
        scenes.push_back(std::move(s));
    }
    return scenes;
}

}  // namespace avatar::render
