#include "RayTracer.h"

#include <avatar/common/Error.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace avatar::render::detail {

namespace {

constexpr double kEpsilonMm = 1e-9;

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

}  // namespace

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
            case Shape::Sphere:
                w.prims.push_back(sphere(object, 0, t.centreMm, t.radiusMm, t.albedo));
                if (t.secondAlbedo) {
                    w.prims.back().twoTone = true;
                    w.prims.back().split = t.splitNormal / cv::norm(t.splitNormal);
                    w.prims.back().splitOffset = t.splitOffsetMm;
                    w.prims.back().albedo2 = *t.secondAlbedo;
                }
                break;
            case Shape::Disc: {
                Prim p;
                p.kind = PrimKind::Disc;
                p.object = object;
                p.centre = t.centreMm;
                p.radius = t.radiusMm;
                p.normal = t.normal / cv::norm(t.normal);
                p.albedo = t.albedo;
                if (t.secondAlbedo) {
                    p.twoTone = true;
                    p.split = t.splitNormal / cv::norm(t.splitNormal);
                    p.splitOffset = t.splitOffsetMm;
                    p.albedo2 = *t.secondAlbedo;
                }
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

namespace {

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
    if (p.twoTone && p.split.dot(x - p.centre) > p.splitOffset) {
        albedo = p.albedo2;
        part = 1;
    }
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

}  // namespace

Sample Tracer::trace(double u, double v, bool shade) const {
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
        const Lighting& l = w_.lighting;
        for (std::size_t c = 0; c < 3; ++c) s.radiance[c] = (l.background[c] + l.backscatter[c]) * l.darknessFactor;
        return s;
    }
    const double t = targetFirst ? tTarget : tOther;
    s.sig.object = hit->object;
    s.sig.part = hit->part;
    // Only a board's and a two-tone target's part depends on where it is hit.
    if (!shade && hit->kind != PrimKind::Board && !hit->twoTone) return s;
    const cv::Vec3d x = o + t * d;
    cv::Vec3d n;
    Rgb albedo;
    int part = hit->part;
    surfaceAt(w_, *hit, x, d, n, albedo, part);
    s.sig.part = part;
    if (shade) s.radiance = shadeAt(x, n, albedo, t);
    return s;
}


Rgb Tracer::shadeAt(const cv::Vec3d& x, const cv::Vec3d& n, const Rgb& albedo, double viewMm) const {
    const Lighting& l = w_.lighting;
    const cv::Vec3d toLight = l.lightPositionMm - x;
    const double lightMm = cv::norm(toLight);
    const double cosine = lightMm > 0.0 ? std::max(0.0, n.dot(toLight) / lightMm) : 0.0;
    const double falloff = l.inverseSquare ? std::pow(l.referenceDistanceMm / lightMm, 2.0) : 1.0;
    Rgb out;
    for (std::size_t c = 0; c < 3; ++c) {
        const double k = l.attenuationPerM[c] + l.turbidityPerM;
        const double viewLoss = std::exp(-k * viewMm / 1000.0);
        const double lightLoss = std::exp(-k * lightMm / 1000.0);
        out[c] = albedo[c] * l.darknessFactor *
                 (l.ambient[c] + l.lightIntensity[c] * cosine * falloff * lightLoss) * viewLoss;
        if (l.backscatter[c] != 0.0) out[c] += l.darknessFactor * l.backscatter[c] * (1.0 - viewLoss);
    }
    return out;
}

}  // namespace avatar::render::detail
