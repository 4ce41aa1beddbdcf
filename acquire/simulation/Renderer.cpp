#include <avatar/render/Renderer.h>

#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>

namespace avatar::render {

SensorFormat sensorFormatFrom(const CameraHardwareConfig& camera) {
    SensorFormat f;
    f.width = camera.width;
    f.height = camera.height;
    f.bitDepth = camera.bitDepth;
    f.format = camera.channels == 3 ? PixelFormat::Bgr : camera.bayer ? PixelFormat::Bayer : PixelFormat::Mono;
    f.bayerPattern = camera.bayerPattern;
    f.fileByteOrder = camera.endianSwap ? ByteOrder::Big : ByteOrder::Little;
    return f;
}

void RenderOptions::validate() const {
    auto fail = [](const std::string& field, const std::string& problem) {
        throw InvalidArgument("RenderOptions." + field + ": " + problem);
    };
    if (sensor.width < 2 || sensor.width > 16384)
        fail("sensor.width", "expected 2..16384, got " + std::to_string(sensor.width));
    if (sensor.height < 2 || sensor.height > 16384)
        fail("sensor.height", "expected 2..16384, got " + std::to_string(sensor.height));
    if (sensor.bitDepth < 1 || sensor.bitDepth > 16)
        fail("sensor.bitDepth", "expected 1..16, got " + std::to_string(sensor.bitDepth));
    if (sensor.format != PixelFormat::Bayer && sensor.format != PixelFormat::Bgr && sensor.format != PixelFormat::Mono)
        fail("sensor.format", "expected bayer, bgr or mono, got " + std::string(avatar::toString(sensor.format)));
    if (supersampling < 1 || supersampling > 16)
        fail("supersampling", "expected 1..16, got " + std::to_string(supersampling));
}

std::string_view toString(TargetVisibility visibility) {
    switch (visibility) {
        case TargetVisibility::Full: return "full";
        case TargetVisibility::Partial: return "partial";
        case TargetVisibility::None: return "none";
    }
    return "?";
}

const TargetTruth& GroundTruth::target(const std::string& name) const {
    for (const auto& t : targets)
        if (t.name == name) return t;
    throw InvalidArgument("GroundTruth::target: no target named '" + name + "' in scene '" + sceneName + "'");
}

namespace {

log4cpp::Category& logger() { return logging::category("render"); }

constexpr double kEpsilonMm = 1e-9;

enum class PrimKind { Sphere, Disc, Box, Plane, Board };

/// One primitive surface. `object` is the target index (< number of targets) or
/// a larger id for scenery; `part` separates differently coloured parts.
struct Prim {
    PrimKind kind{PrimKind::Sphere};
    int object{0};
    int part{0};
    cv::Vec3d centre;
    double radius{0.0};
    cv::Vec3d normal;      ///< disc, plane (unit, facing the camera side for the plane)
    cv::Matx33d rotation;  ///< box, board: local -> left
    cv::Vec3d half;        ///< box half sizes; board: x/y extent (min in half, max in extentMax)
    cv::Vec3d extentMax;
    Rgb albedo{0, 0, 0};
};

/// Signature of what a sample sees; pixels whose samples agree are not supersampled.
struct Signature {
    int object{-1};  ///< -1 background, -2 no ray (outside the invertible distortion)
    int part{0};
    std::uint64_t targets{0};  ///< every target the ray passes through, visible or not
    bool operator==(const Signature& o) const {
        return object == o.object && part == o.part && targets == o.targets;
    }
};

struct Sample {
    Signature sig;
    Rgb radiance{0, 0, 0};
};

// -------------------------------------------------------------- procedural texture

std::uint64_t splitmix(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

double latticeValue(std::int64_t ix, std::int64_t iy, std::uint64_t seed) {
    const std::uint64_t h = splitmix(seed ^ splitmix(static_cast<std::uint64_t>(ix) * 0x632be59bd9b4e019ULL ^
                                                     static_cast<std::uint64_t>(iy)));
    return static_cast<double>(h >> 11) * (2.0 / 9007199254740992.0) - 1.0;  // [-1, 1)
}

double valueNoise(double x, double y, std::uint64_t seed) {
    const double fx = std::floor(x), fy = std::floor(y);
    const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy);
    const double tx = x - fx, ty = y - fy;
    const double sx = tx * tx * (3.0 - 2.0 * tx), sy = ty * ty * (3.0 - 2.0 * ty);
    const double a = latticeValue(ix, iy, seed), b = latticeValue(ix + 1, iy, seed);
    const double c = latticeValue(ix, iy + 1, seed), d = latticeValue(ix + 1, iy + 1, seed);
    return (a + (b - a) * sx) * (1.0 - sy) + (c + (d - c) * sx) * sy;
}

/// Sand: four octaves of value noise, in [-1, 1].
double sandTexture(double u, double v, double scaleMm, std::uint64_t seed) {
    double sum = 0.0, amplitude = 1.0, norm = 0.0, scale = scaleMm;
    for (int octave = 0; octave < 4; ++octave) {
        sum += amplitude * valueNoise(u / scale, v / scale, seed + static_cast<std::uint64_t>(octave) * 7919u);
        norm += amplitude;
        amplitude *= 0.5;
        scale *= 0.5;
    }
    return sum / norm;
}

// -------------------------------------------------------------- the scene as primitives

struct World {
    std::vector<Prim> prims;
    int targetCount{0};
    int seabedObject{-1};
    int boardObject{-1};
    // seabed
    cv::Vec3d seabedPoint, seabedE1, seabedE2;
    Seabed seabed;
    // checkerboard
    std::optional<Checkerboard> board;
    Lighting lighting;
};

Prim sphere(int object, int part, const cv::Vec3d& c, double r, const Rgb& albedo) {
    Prim p;
    p.kind = PrimKind::Sphere;
    p.object = object;
    p.part = part;
    p.centre = c;
    p.radius = r;
    p.albedo = albedo;
    return p;
}

Prim box(int object, int part, const cv::Vec3d& c, const cv::Vec3d& half, const cv::Matx33d& rotation,
         const Rgb& albedo) {
    Prim p;
    p.kind = PrimKind::Box;
    p.object = object;
    p.part = part;
    p.centre = c;
    p.half = half;
    p.rotation = rotation;
    p.albedo = albedo;
    return p;
}

World buildWorld(const Scene& scene, const std::optional<RigidTransform>& baseTVision,
                 std::vector<TargetTruth>& truths) {
    World w;
    w.lighting = scene.lighting;
    int object = 0;
    for (const TargetSpec& t : scene.targets) {
        TargetTruth truth;
        truth.name = t.name;
        truth.type = t.type;
        truth.shape = t.shape;
        truth.centreLeftMm = {t.centreMm[0], t.centreMm[1], t.centreMm[2]};
        truths.push_back(truth);
        switch (t.shape) {
            case Shape::Sphere: w.prims.push_back(sphere(object, 0, t.centreMm, t.radiusMm, t.albedo)); break;
            case Shape::Disc: {
                Prim p;
                p.kind = PrimKind::Disc;
                p.object = object;
                p.centre = t.centreMm;
                p.radius = t.radiusMm;
                p.normal = t.normal / cv::norm(t.normal);
                p.albedo = t.albedo;
                w.prims.push_back(p);
                break;
            }
            case Shape::Duck: {
                const cv::Matx33d r = rodrigues(t.om);
                const double s = t.radiusMm;
                const cv::Vec3d head = t.centreMm + r * cv::Vec3d(0.55 * s, -0.75 * s, 0.0);
                w.prims.push_back(sphere(object, 0, t.centreMm, s, t.albedo));
                w.prims.push_back(sphere(object, 1, head, 0.55 * s, t.albedo));
                w.prims.push_back(box(object, 2, t.centreMm + r * cv::Vec3d(1.2 * s, -0.7 * s, 0.0),
                                      cv::Vec3d(0.25 * s, 0.08 * s, 0.16 * s), r, t.beakAlbedo));
                break;
            }
            case Shape::Box:
                w.prims.push_back(box(object, 0, t.centreMm, t.halfSizeMm, rodrigues(t.om), t.albedo));
                break;
        }
        ++object;
    }
    if (!scene.armMarkers.empty() && !baseTVision)
        throw SceneError("<memory>", 0, "/scene/armMarker[1]",
                         "an arm marker is placed in the manipulator base frame and needs a "
                         "registration: set StereoSystemConfig::baseTVision or the scene's <registration>");
    for (const ArmMarker& a : scene.armMarkers) {
        const RigidTransform visionTBase = inverse(*baseTVision);
        const cv::Point3d c = transformPoint(visionTBase, {a.positionBaseMm[0], a.positionBaseMm[1], a.positionBaseMm[2]});
        const cv::Matx33d r = rotationMatrix(visionTBase) * rodrigues(a.omBase);
        TargetTruth truth;
        truth.name = a.name;
        truth.type = a.type;
        truth.shape = Shape::Box;
        truth.centreLeftMm = c;
        truths.push_back(truth);
        w.prims.push_back(box(object, 0, cv::Vec3d(c), a.halfSizeMm, r, a.albedo));
        ++object;
    }
    w.targetCount = object;
    for (const Occluder& o : scene.occluders) {
        if (o.shape == Shape::Box) w.prims.push_back(box(object, 0, o.centreMm, o.halfSizeMm, rodrigues(o.om), o.albedo));
        else w.prims.push_back(sphere(object, 0, o.centreMm, o.radiusMm, o.albedo));
        ++object;
    }
    if (scene.checkerboard) {
        const Checkerboard& b = *scene.checkerboard;
        Prim p;
        p.kind = PrimKind::Board;
        p.object = w.boardObject = object++;
        p.rotation = rodrigues(b.om);
        p.centre = b.positionMm;
        p.normal = p.rotation * cv::Vec3d(0, 0, -1);
        const double m = (1.0 + b.marginSquares) * b.squareMm;
        p.half = {-m, -m, 0.0};
        p.extentMax = {(b.squaresX - 1) * b.squareMm + m, (b.squaresY - 1) * b.squareMm + m, 0.0};
        w.prims.push_back(p);
        w.board = b;
    }
    if (scene.seabed.enabled) {
        const double tilt = scene.seabed.tiltDeg * M_PI / 180.0;
        Prim p;
        p.kind = PrimKind::Plane;
        p.object = w.seabedObject = object++;
        p.centre = {0.0, 0.0, scene.seabed.distanceMm};
        p.normal = {0.0, -std::sin(tilt), -std::cos(tilt)};
        p.albedo = scene.seabed.albedo;
        w.prims.push_back(p);
        w.seabedPoint = p.centre;
        w.seabedE1 = {1.0, 0.0, 0.0};
        w.seabedE2 = p.normal.cross(w.seabedE1);
        w.seabed = scene.seabed;
    }
    return w;
}

/// Ray parameter of the first hit in front of the origin, or +inf.
double intersect(const Prim& p, const cv::Vec3d& o, const cv::Vec3d& d, int& part) {
    constexpr double inf = std::numeric_limits<double>::infinity();
    part = p.part;
    switch (p.kind) {
        case PrimKind::Sphere: {
            const cv::Vec3d oc = o - p.centre;
            const double b = oc.dot(d);
            const double c = oc.dot(oc) - p.radius * p.radius;
            const double disc = b * b - c;
            if (disc < 0.0) return inf;
            const double s = std::sqrt(disc);
            double t = -b - s;
            if (t <= kEpsilonMm) t = -b + s;
            return t > kEpsilonMm ? t : inf;
        }
        case PrimKind::Disc:
        case PrimKind::Plane: {
            const double denom = p.normal.dot(d);
            if (std::abs(denom) < 1e-15) return inf;
            const double t = p.normal.dot(p.centre - o) / denom;
            if (!(t > kEpsilonMm)) return inf;
            if (p.kind == PrimKind::Disc) {
                const cv::Vec3d q = o + t * d - p.centre;
                if (q.dot(q) > p.radius * p.radius) return inf;
            }
            return t;
        }
        case PrimKind::Board: {
            const double denom = p.normal.dot(d);
            if (std::abs(denom) < 1e-15) return inf;
            const double t = p.normal.dot(p.centre - o) / denom;
            if (!(t > kEpsilonMm)) return inf;
            const cv::Vec3d q = p.rotation.t() * (o + t * d - p.centre);
            if (q[0] < p.half[0] || q[0] > p.extentMax[0] || q[1] < p.half[1] || q[1] > p.extentMax[1])
                return inf;
            return t;
        }
        case PrimKind::Box: {
            const cv::Matx33d rt = p.rotation.t();
            const cv::Vec3d ol = rt * (o - p.centre);
            const cv::Vec3d dl = rt * d;
            double tNear = -inf, tFar = inf;
            for (int i = 0; i < 3; ++i) {
                if (std::abs(dl[i]) < 1e-300) {
                    if (ol[i] < -p.half[i] || ol[i] > p.half[i]) return inf;
                    continue;
                }
                double t1 = (-p.half[i] - ol[i]) / dl[i];
                double t2 = (p.half[i] - ol[i]) / dl[i];
                if (t1 > t2) std::swap(t1, t2);
                tNear = std::max(tNear, t1);
                tFar = std::min(tFar, t2);
            }
            if (tNear > tFar) return inf;
            if (tNear > kEpsilonMm) return tNear;
            return tFar > kEpsilonMm ? tFar : inf;
        }
    }
    return inf;
}

/// Surface normal (unit, facing against d) and albedo at a hit; sets the part of a board.
void surfaceAt(const World& w, const Prim& p, const cv::Vec3d& x, const cv::Vec3d& d, cv::Vec3d& n,
               Rgb& albedo, int& part) {
    albedo = p.albedo;
    switch (p.kind) {
        case PrimKind::Sphere: n = (x - p.centre) / p.radius; break;
        case PrimKind::Disc: n = p.normal; break;
        case PrimKind::Plane: {
            n = p.normal;
            const cv::Vec3d q = x - w.seabedPoint;
            const double k = 1.0 + w.seabed.textureContrast *
                                       sandTexture(q.dot(w.seabedE1), q.dot(w.seabedE2),
                                                   w.seabed.textureScaleMm, w.seabed.textureSeed);
            for (std::size_t c = 0; c < 3; ++c) albedo[c] = std::clamp(p.albedo[c] * k, 0.0, 1.0);
            break;
        }
        case PrimKind::Board: {
            n = p.normal;
            const cv::Vec3d q = p.rotation.t() * (x - p.centre);
            const Checkerboard& b = *w.board;
            const long ix = static_cast<long>(std::floor(q[0] / b.squareMm)) + 1;
            const long iy = static_cast<long>(std::floor(q[1] / b.squareMm)) + 1;
            const bool inside = ix >= 0 && ix < b.squaresX && iy >= 0 && iy < b.squaresY;
            const bool dark = inside && ((ix + iy) % 2 == 0);
            albedo = dark ? b.dark : b.light;
            part = dark ? 1 : 2;
            break;
        }
        case PrimKind::Box: {
            const cv::Vec3d l = p.rotation.t() * (x - p.centre);
            int axis = 0;
            double best = -1.0;
            for (int i = 0; i < 3; ++i) {
                const double r = std::abs(l[i]) / p.half[i];
                if (r > best) {
                    best = r;
                    axis = i;
                }
            }
            cv::Vec3d nl(0, 0, 0);
            nl[axis] = l[axis] > 0 ? 1.0 : -1.0;
            n = p.rotation * nl;
            break;
        }
    }
    if (n.dot(d) > 0.0) n = -n;
}

/// One camera as the renderer needs it: its intrinsics and its pose in the left frame.
struct CameraRig {
    CameraIntrinsics intrinsics;
    cv::Matx33d leftRCamera;
    cv::Vec3d centreLeftMm;
};

class Tracer {
public:
    Tracer(const World& world, const CameraRig& rig) : w_(world), rig_(rig) {}

    Sample trace(double u, double v, bool shade) const {
        Sample s;
        const auto xn = normalizePixelExact(rig_.intrinsics, {u, v});
        if (!xn) {
            s.sig.object = -2;
            return s;
        }
        cv::Vec3d d = rig_.leftRCamera * cv::Vec3d(xn->x, xn->y, 1.0);
        d /= cv::norm(d);
        const cv::Vec3d& o = rig_.centreLeftMm;
        constexpr double inf = std::numeric_limits<double>::infinity();
        double tTarget = inf, tOther = inf;
        const Prim* bestTarget = nullptr;
        const Prim* bestOther = nullptr;
        for (const Prim& p : w_.prims) {
            int part = 0;
            const double t = intersect(p, o, d, part);
            if (t == inf) continue;
            if (p.object < w_.targetCount) {
                s.sig.targets |= std::uint64_t{1} << p.object;
                if (t < tTarget) {
                    tTarget = t;
                    bestTarget = &p;
                }
            } else if (t < tOther) {
                tOther = t;
                bestOther = &p;
            }
        }
        // A target wins a tie with scenery (e.g. a sand dollar lying on the seabed).
        const bool targetFirst = bestTarget && tTarget <= tOther * (1.0 + 1e-9);
        const Prim* hit = targetFirst ? bestTarget : bestOther;
        if (!hit) {
            for (std::size_t c = 0; c < 3; ++c)
                s.radiance[c] = w_.lighting.background[c] * w_.lighting.darknessFactor;
            return s;
        }
        const double t = targetFirst ? tTarget : tOther;
        s.sig.object = hit->object;
        s.sig.part = hit->part;
        // Only a board's part (checker colour) depends on where it is hit.
        if (!shade && hit->kind != PrimKind::Board) return s;
        const cv::Vec3d x = o + t * d;
        cv::Vec3d n;
        Rgb albedo;
        int part = hit->part;
        surfaceAt(w_, *hit, x, d, n, albedo, part);
        s.sig.part = part;
        if (shade) s.radiance = shadeAt(x, n, albedo, t);
        return s;
    }

private:
    Rgb shadeAt(const cv::Vec3d& x, const cv::Vec3d& n, const Rgb& albedo, double viewMm) const {
        const Lighting& l = w_.lighting;
        const cv::Vec3d toLight = l.lightPositionMm - x;
        const double lightMm = cv::norm(toLight);
        const double cosine = lightMm > 0.0 ? std::max(0.0, n.dot(toLight) / lightMm) : 0.0;
        const double falloff = l.inverseSquare ? std::pow(l.referenceDistanceMm / lightMm, 2.0) : 1.0;
        Rgb out;
        for (std::size_t c = 0; c < 3; ++c) {
            const double viewLoss = std::exp(-l.attenuationPerM[c] * viewMm / 1000.0);
            const double lightLoss = std::exp(-l.attenuationPerM[c] * lightMm / 1000.0);
            out[c] = albedo[c] * l.darknessFactor *
                     (l.ambient[c] + l.lightIntensity[c] * cosine * falloff * lightLoss) * viewLoss;
        }
        return out;
    }

    const World& w_;
    const CameraRig& rig_;
};

/// Per-target sums of one image row.
struct TargetAccumulator {
    double visible{0.0};
    double sumX{0.0};
    double sumY{0.0};
    double potential{0.0};
    bool atBorder{false};
};

struct CameraRender {
    cv::Mat radiance;  ///< CV_64FC3, linear R, G, B per pixel (before strobe and sensor)
    std::vector<TargetAccumulator> targets;
    std::uint64_t supersampled{0};
    std::uint64_t rays{0};
    std::uint64_t noInverse{0};
};

CameraRender renderCamera(const World& world, const CameraRig& rig, const RenderOptions& options) {
    const int width = options.sensor.width, height = options.sensor.height;
    const int n = options.supersampling;
    const bool adaptive = options.adaptive && n > 1;
    const Tracer tracer(world, rig);
    const auto nTargets = static_cast<std::size_t>(world.targetCount);

    // Pass 1 (adaptive): what the pixel corners see.
    std::vector<Signature> corners;
    if (adaptive) {
        corners.resize(static_cast<std::size_t>(width + 1) * static_cast<std::size_t>(height + 1));
        cv::parallel_for_(cv::Range(0, height + 1), [&](const cv::Range& rows) {
            for (int j = rows.start; j < rows.end; ++j)
                for (int i = 0; i <= width; ++i)
                    corners[static_cast<std::size_t>(j) * static_cast<std::size_t>(width + 1) +
                            static_cast<std::size_t>(i)] = tracer.trace(i - 0.5, j - 0.5, false).sig;
        });
    }

    // Pass 2: every pixel, row by row; sums are kept per row and reduced in
    // row order, so the result does not depend on the threads.
    CameraRender out;
    out.radiance.create(height, width, CV_64FC3);
    std::vector<TargetAccumulator> rowSums(static_cast<std::size_t>(height) * nTargets);
    std::vector<std::uint64_t> rowSupersampled(static_cast<std::size_t>(height), 0);
    std::vector<std::uint64_t> rowNoInverse(static_cast<std::size_t>(height), 0);
    cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
        for (int j = rows.start; j < rows.end; ++j) {
            TargetAccumulator* acc = rowSums.data() + static_cast<std::size_t>(j) * nTargets;
            auto* pixels = out.radiance.ptr<cv::Vec3d>(j);
            for (int i = 0; i < width; ++i) {
                const bool border = i == 0 || j == 0 || i == width - 1 || j == height - 1;
                auto add = [&](const Sample& s, double x, double y, double weight) {
                    if (s.sig.object == -2) ++rowNoInverse[static_cast<std::size_t>(j)];
                    if (s.sig.object >= 0 && s.sig.object < world.targetCount) {
                        TargetAccumulator& a = acc[s.sig.object];
                        a.visible += weight;
                        a.sumX += weight * x;
                        a.sumY += weight * y;
                    }
                    for (std::uint64_t m = s.sig.targets; m; m &= m - 1) {
                        TargetAccumulator& a = acc[__builtin_ctzll(m)];
                        a.potential += weight;
                        a.atBorder = a.atBorder || border;
                    }
                };
                const Sample centre = tracer.trace(i, j, true);
                bool uniform = n == 1;
                if (adaptive) {
                    const std::size_t stride = static_cast<std::size_t>(width + 1);
                    const std::size_t k = static_cast<std::size_t>(j) * stride + static_cast<std::size_t>(i);
                    uniform = corners[k] == centre.sig && corners[k + 1] == centre.sig &&
                              corners[k + stride] == centre.sig && corners[k + stride + 1] == centre.sig;
                }
                if (uniform) {
                    add(centre, i, j, 1.0);
                    pixels[i] = cv::Vec3d(centre.radiance[0], centre.radiance[1], centre.radiance[2]);
                    continue;
                }
                ++rowSupersampled[static_cast<std::size_t>(j)];
                const double weight = 1.0 / (n * n);
                cv::Vec3d sum(0, 0, 0);
                for (int sy = 0; sy < n; ++sy)
                    for (int sx = 0; sx < n; ++sx) {
                        const double x = i - 0.5 + (sx + 0.5) / n;
                        const double y = j - 0.5 + (sy + 0.5) / n;
                        const Sample s = tracer.trace(x, y, true);
                        add(s, x, y, weight);
                        sum += cv::Vec3d(s.radiance[0], s.radiance[1], s.radiance[2]);
                    }
                pixels[i] = sum * weight;
            }
        }
    });

    out.targets.assign(nTargets, {});
    for (int j = 0; j < height; ++j) {
        for (std::size_t t = 0; t < nTargets; ++t) {
            const TargetAccumulator& r = rowSums[static_cast<std::size_t>(j) * nTargets + t];
            TargetAccumulator& a = out.targets[t];
            a.visible += r.visible;
            a.sumX += r.sumX;
            a.sumY += r.sumY;
            a.potential += r.potential;
            a.atBorder = a.atBorder || r.atBorder;
        }
        out.supersampled += rowSupersampled[static_cast<std::size_t>(j)];
        out.noInverse += rowNoInverse[static_cast<std::size_t>(j)];
    }
    const auto pixels = static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
    out.rays = pixels + out.supersampled * static_cast<std::uint64_t>(n * n) +
               (adaptive ? static_cast<std::uint64_t>(width + 1) * static_cast<std::uint64_t>(height + 1) : 0);
    return out;
}

/// 0 = red, 1 = green, 2 = blue at (x, y) of a mosaic named by its first row.
int bayerChannel(BayerPattern pattern, int x, int y) {
    static const int table[4][4] = {
        // (even x, even y), (odd x, even y), (even x, odd y), (odd x, odd y)
        {2, 1, 1, 0},  // BG: B G / G R
        {1, 2, 0, 1},  // GB: G B / R G
        {0, 1, 1, 2},  // RG: R G / G B
        {1, 0, 2, 1},  // GR: G R / B G
    };
    return table[static_cast<int>(pattern)][(x & 1) + 2 * (y & 1)];
}

/// Strobe falloff, the sensor response and noise: radiance -> digital numbers.
cv::Mat digitize(const cv::Mat& radiance, const Scene& scene, const RenderOptions& options,
                 std::mt19937_64& rng) {
    const SensorFormat& f = options.sensor;
    const SensorNoise& sn = scene.sensor;
    const Strobe& strobe = scene.lighting.strobe;
    const double maxDn = std::ldexp(1.0, f.bitDepth) - 1.0;
    const bool readNoise = options.noise && sn.readNoiseDn > 0.0;
    const bool shotNoise = options.noise && sn.shotNoise;
    std::normal_distribution<double> gauss(0.0, 1.0);
    const int depth = f.bitDepth > 8 ? CV_16U : CV_8U;
    const bool colour = f.format == PixelFormat::Bgr;
    cv::Mat image(radiance.size(), CV_MAKETYPE(depth, colour ? 3 : 1));

    // Light reaching the pixel (strobe falloff included), relative to full well.
    auto signal = [&](double r, int channel, int x, int y) {
        double s = r * sn.exposure;
        if (strobe.enabled) {
            const double d = std::hypot(x - strobe.centrePx[0], y - strobe.centrePx[1]);
            const auto& ch = strobe.rgb[static_cast<std::size_t>(channel)];
            s *= ch.coefficient * std::exp(ch.exponent * d);
        }
        return s;
    };
    auto digital = [&](double s) {
        double electrons = s * sn.fullWellElectrons;
        if (shotNoise) electrons += std::sqrt(std::max(electrons, 0.0)) * gauss(rng);
        double dn = electrons / sn.fullWellElectrons * maxDn + sn.blackLevelDn;
        if (readNoise) dn += sn.readNoiseDn * gauss(rng);
        return std::clamp(std::round(dn), 0.0, maxDn);
    };
    auto store1 = [&](int x, int y, double v) {
        if (depth == CV_16U) image.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(v);
        else image.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(v);
    };
    for (int y = 0; y < radiance.rows; ++y) {
        const auto* in = radiance.ptr<cv::Vec3d>(y);
        for (int x = 0; x < radiance.cols; ++x) {
            switch (f.format) {
                case PixelFormat::Bayer: {
                    const int c = bayerChannel(f.bayerPattern, x, y);
                    store1(x, y, digital(signal(in[x][c], c, x, y)));
                    break;
                }
                case PixelFormat::Mono:  // a panchromatic pixel: the mean of the three bands
                    store1(x, y, digital((signal(in[x][0], 0, x, y) + signal(in[x][1], 1, x, y) +
                                          signal(in[x][2], 2, x, y)) / 3.0));
                    break;
                case PixelFormat::Bgr:
                    for (int c = 0; c < 3; ++c) {  // BGR order in the image
                        const double v = digital(signal(in[x][c], c, x, y));
                        if (depth == CV_16U) image.at<cv::Vec3w>(y, x)[2 - c] = static_cast<std::uint16_t>(v);
                        else image.at<cv::Vec3b>(y, x)[2 - c] = static_cast<std::uint8_t>(v);
                    }
                    break;
            }
        }
    }
    return image;
}

TargetView viewOf(const TargetAccumulator& a, const std::optional<cv::Point2d>& projected) {
    TargetView v;
    v.projectedCentrePx = projected;
    v.areaPx = a.visible;
    if (a.visible > 0.0) v.silhouetteCentroidPx = cv::Point2d(a.sumX / a.visible, a.sumY / a.visible);
    v.occluded = a.potential - a.visible > 1e-9 * std::max(1.0, a.potential);
    v.atBorder = a.atBorder;
    v.visibility = a.visible <= 0.0 ? TargetVisibility::None
                   : (v.occluded || v.atBorder) ? TargetVisibility::Partial
                                                : TargetVisibility::Full;
    return v;
}

}  // namespace

RenderResult render(const Scene& scene, const StereoSystemConfig& stereo, const RenderOptions& options) {
    const auto start = std::chrono::steady_clock::now();
    options.validate();
    validateScene(scene);

    const std::optional<RigidTransform> baseTVision = stereo.baseTVision ? stereo.baseTVision : scene.baseTVision;
    if (stereo.baseTVision && scene.baseTVision && !(*stereo.baseTVision == *scene.baseTVision))
        logger().notice("scene '%s': the stereo configuration's registration replaces the scene's",
                        scene.name.c_str());

    GroundTruth truth;
    truth.sceneName = scene.name;
    truth.seed = options.seed;
    truth.width = options.sensor.width;
    truth.height = options.sensor.height;
    truth.supersampling = options.supersampling;
    truth.adaptive = options.adaptive;
    truth.baseTVision = baseTVision;
    const World world = buildWorld(scene, baseTVision, truth.targets);

    const RigidTransform rTl = rightTLeft(stereo);
    const CameraRig leftRig{stereo.left, cv::Matx33d::eye(), cv::Vec3d(0, 0, 0)};
    const cv::Matx33d lRr = rotationMatrix(rTl).t();
    const cv::Vec3d t(rTl.translationMm[0], rTl.translationMm[1], rTl.translationMm[2]);
    const CameraRig rightRig{stereo.right, lRr, -(lRr * t)};

    const CameraRender left = renderCamera(world, leftRig, options);
    const CameraRender right = renderCamera(world, rightRig, options);

    for (std::size_t i = 0; i < truth.targets.size(); ++i) {
        TargetTruth& tt = truth.targets[i];
        tt.centreRightMm = transformPoint(rTl, tt.centreLeftMm);
        if (baseTVision) tt.centreBaseMm = transformPoint(*baseTVision, tt.centreLeftMm);
        tt.left = viewOf(left.targets[i], projectPoint(stereo.left, tt.centreLeftMm));
        tt.right = viewOf(right.targets[i], projectPoint(stereo.right, tt.centreRightMm));
    }
    if (world.board) {
        const Checkerboard& b = *world.board;
        CheckerboardTruth cb;
        cb.cornersX = b.squaresX - 1;
        cb.cornersY = b.squaresY - 1;
        cb.squareMm = b.squareMm;
        const RigidTransform leftTBoard = makeRigidTransform(rodrigues(b.om), b.positionMm);
        for (int y = 0; y < cb.cornersY; ++y)
            for (int x = 0; x < cb.cornersX; ++x) {
                const cv::Point3d p = transformPoint(leftTBoard, {x * b.squareMm, y * b.squareMm, 0.0});
                cb.cornersLeftMm.push_back(p);
                const auto l = projectPoint(stereo.left, p);
                const auto r = projectPoint(stereo.right, transformPoint(rTl, p));
                const cv::Point2d nan(std::nan(""), std::nan(""));
                cb.cornersLeftPx.push_back(l.value_or(nan));
                cb.cornersRightPx.push_back(r.value_or(nan));
            }
        truth.checkerboard = cb;
    }

    std::mt19937_64 rng(options.seed);
    cv::Mat leftImage = digitize(left.radiance, scene, options, rng);
    cv::Mat rightImage = digitize(right.radiance, scene, options, rng);
    PairLayout layout;
    layout.format = options.sensor.format;
    layout.bayerPattern = options.sensor.bayerPattern;
    layout.bitDepth = options.sensor.bitDepth;
    RenderResult result{StereoImagePair(leftImage, rightImage, layout), std::move(truth)};

    RenderStats& stats = result.truth.stats;
    stats.pixels = 2ull * static_cast<std::uint64_t>(options.sensor.width) *
                   static_cast<std::uint64_t>(options.sensor.height);
    stats.supersampledPixels = left.supersampled + right.supersampled;
    stats.rays = left.rays + right.rays;
    stats.raysWithoutInverse = left.noInverse + right.noInverse;
    stats.milliseconds =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (stats.raysWithoutInverse > 0)
        logger().warn("scene '%s': %llu samples fall outside the invertible lens distortion and are black",
                      scene.name.c_str(), static_cast<unsigned long long>(stats.raysWithoutInverse));
    logger().info("rendered scene '%s' %dx%d: %.1f ms, %llu of %llu pixels supersampled %dx%d, %llu rays",
                  scene.name.c_str(), options.sensor.width, options.sensor.height, stats.milliseconds,
                  static_cast<unsigned long long>(stats.supersampledPixels),
                  static_cast<unsigned long long>(stats.pixels), options.supersampling,
                  options.supersampling, static_cast<unsigned long long>(stats.rays));
    return result;
}

}  // namespace avatar::render
