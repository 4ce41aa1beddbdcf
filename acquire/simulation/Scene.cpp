#include <avatar/render/Scene.h>

#include <avatar/common/internal/Text.h>

#include <avatar/common/CameraModel.h>

#include <tinyxml2.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>

namespace avatar::render {

std::string_view toString(Shape shape) {
    switch (shape) {
        case Shape::Sphere: return "sphere";
        case Shape::Disc: return "disc";
        case Shape::Duck: return "duck";
        case Shape::Box: return "box";
    }
    return "?";
}

namespace {

using text::formatDouble;
using text::formatDoubles;

/// Where a value came from, for error messages.
struct Context {
    std::string source;
    int line{0};
    std::string path;
    [[noreturn]] void fail(const std::string& attribute, const std::string& problem) const {
        throw SceneError(source, line, attribute.empty() ? path : path + "@" + attribute, problem);
    }
};

// ---------------------------------------------------------------- semantic checks
// Shared by the file reader (with line numbers) and validateScene().

void checkFinite(const Context& c, const char* attr, const cv::Vec3d& v) {
    for (int i = 0; i < 3; ++i)
        if (!std::isfinite(v[i])) c.fail(attr, "expected finite numbers, got '" + formatDoubles(v, 3) + "'");
}

void checkPositive(const Context& c, const char* attr, double v) {
    if (!(v > 0.0) || !std::isfinite(v))
        c.fail(attr, "expected a number > 0, got '" + formatDouble(v) + "'");
}

void checkRange(const Context& c, const char* attr, double v, double lo, double hi) {
    if (!(v >= lo && v <= hi))
        c.fail(attr, "expected a number in [" + formatDouble(lo) + ", " + formatDouble(hi) +
                         "], got '" + formatDouble(v) + "'");
}

void checkPositive3(const Context& c, const char* attr, const cv::Vec3d& v) {
    for (int i = 0; i < 3; ++i)
        if (!(v[i] > 0.0) || !std::isfinite(v[i]))
            c.fail(attr, "expected three numbers > 0, got '" + formatDoubles(v, 3) + "'");
}

void checkRgb(const Context& c, const char* attr, const Rgb& v, double hi) {
    for (double x : v)
        if (!(x >= 0.0 && x <= hi))
            c.fail(attr, "expected three numbers in [0, " + formatDouble(hi) + "], got '" +
                             formatDoubles(v, 3) + "'");
}

void checkRotation(const Context& c, const char* attr, const RigidTransform& t) {
    const cv::Matx33d r = rotationMatrix(t);
    const cv::Matx33d e = r * r.t() - cv::Matx33d::eye();
    double worst = 0.0;
    for (double x : e.val) worst = std::max(worst, std::abs(x));
    if (!(worst < 1e-9) || !(cv::determinant(r) > 0.0))
        c.fail(attr, "the rotation is not a proper rotation matrix");
    checkFinite(c, attr, cv::Vec3d(t.translationMm[0], t.translationMm[1], t.translationMm[2]));
}

void checkSeabed(const Context& c, const Seabed& s) {
    checkPositive(c, "distanceMm", s.distanceMm);
    checkRange(c, "tiltDeg", s.tiltDeg, -80.0, 80.0);
    checkRgb(c, "albedo", s.albedo, 1.0);
    checkRange(c, "textureContrast", s.textureContrast, 0.0, 1.0);
    checkPositive(c, "textureScaleMm", s.textureScaleMm);
}

void checkLighting(const Context& c, const Lighting& l) {
    checkRgb(c, "ambient", l.ambient, 1e6);
    checkRgb(c, "lightIntensity", l.lightIntensity, 1e6);
    checkFinite(c, "lightPositionMm", l.lightPositionMm);
    checkPositive(c, "referenceDistanceMm", l.referenceDistanceMm);
    checkRange(c, "darknessFactor", l.darknessFactor, 1e-6, 1.0);
}

void checkStrobe(const Context& c, const Strobe& s) {
    if (!std::isfinite(s.centrePx[0]) || !std::isfinite(s.centrePx[1]))
        c.fail("centrePx", "expected two finite numbers");
    static const char* const names[3] = {"red", "green", "blue"};
    for (std::size_t i = 0; i < 3; ++i) {
        const Context ch{c.source, c.line, c.path + "/" + names[i]};
        checkPositive(ch, "coefficient", s.rgb[i].coefficient);
        if (!(s.rgb[i].exponent <= 0.0) || !std::isfinite(s.rgb[i].exponent))
            ch.fail("exponent", "the strobe darkens away from its centre (factor c*exp(e*d)), so "
                                "the exponent must be <= 0, got '" +
                                    formatDouble(s.rgb[i].exponent) + "'");
    }
}

void checkWater(const Context& c, const Lighting& l) {
    checkRgb(c, "attenuationPerM", l.attenuationPerM, 1e3);
    checkRgb(c, "background", l.background, 1e6);
    checkRgb(c, "backscatter", l.backscatter, 1e6);
    checkRange(c, "turbidityPerM", l.turbidityPerM, 0.0, 1e3);
}

void checkSensor(const Context& c, const SensorNoise& s) {
    checkPositive(c, "exposure", s.exposure);
    checkRange(c, "readNoiseDn", s.readNoiseDn, 0.0, 1e5);
    checkPositive(c, "fullWellElectrons", s.fullWellElectrons);
    checkRange(c, "blackLevelDn", s.blackLevelDn, 0.0, 65535.0);
}

void checkName(const Context& c, const std::string& name, std::set<std::string>& names) {
    if (name.empty()) c.fail("name", "a name must not be empty");
    if (!names.insert(name).second) c.fail("name", "duplicate target name '" + name + "'");
}

void checkTarget(const Context& c, const TargetSpec& t) {
    if (t.type.empty()) c.fail("type", "the target type must not be empty");
    checkFinite(c, "centreMm", t.centreMm);
    if (t.shape == Shape::Box) {
        checkPositive3(c, "halfSizeMm", t.halfSizeMm);
    } else {
        checkPositive(c, "radiusMm", t.radiusMm);
    }
    if (t.shape == Shape::Disc && !(cv::norm(t.normal) > 1e-12))
        c.fail("normal", "the disc normal must not be zero");
    checkRgb(c, "albedo", t.albedo, 1.0);
    checkRgb(c, "beakAlbedo", t.beakAlbedo, 1.0);
    if (t.secondAlbedo) {
        checkRgb(c, "secondAlbedo", *t.secondAlbedo, 1.0);
        if (!(cv::norm(t.splitNormal) > 1e-12)) c.fail("splitNormal", "the split normal must not be zero");
    }
}

void checkArmMarker(const Context& c, const ArmMarker& a) {
    if (a.type.empty()) c.fail("type", "the target type must not be empty");
    checkFinite(c, "positionBaseMm", a.positionBaseMm);
    checkPositive3(c, "halfSizeMm", a.halfSizeMm);
    checkRgb(c, "albedo", a.albedo, 1.0);
}

void checkOccluder(const Context& c, const Occluder& o) {
    if (o.shape != Shape::Sphere && o.shape != Shape::Box)
        c.fail("shape", "an occluder is a sphere or a box, got '" + std::string(toString(o.shape)) + "'");
    checkFinite(c, "centreMm", o.centreMm);
    if (o.shape == Shape::Sphere) checkPositive(c, "radiusMm", o.radiusMm);
    else checkPositive3(c, "halfSizeMm", o.halfSizeMm);
    checkRgb(c, "albedo", o.albedo, 1.0);
}

void checkCheckerboard(const Context& c, const Checkerboard& b) {
    if (b.squaresX < 2 || b.squaresX > 100) c.fail("squaresX", "expected 2..100, got " + std::to_string(b.squaresX));
    if (b.squaresY < 2 || b.squaresY > 100) c.fail("squaresY", "expected 2..100, got " + std::to_string(b.squaresY));
    checkPositive(c, "squareMm", b.squareMm);
    checkRange(c, "marginSquares", b.marginSquares, 0.0, 10.0);
    checkFinite(c, "om", cv::Vec3d(b.om[0], b.om[1], b.om[2]));
    checkFinite(c, "positionMm", b.positionMm);
    checkRgb(c, "dark", b.dark, 1.0);
    checkRgb(c, "light", b.light, 1.0);
}

// ---------------------------------------------------------------- XML reading

/// Reads the attributes of one element; finish() rejects any it did not read.
class ElementReader {
public:
    ElementReader(const std::string& source, const tinyxml2::XMLElement& element, std::string path)
        : element_(element), context_{source, element.GetLineNum(), std::move(path)} {}

    const Context& context() const { return context_; }

    std::optional<std::string> raw(const char* name) {
        known_.insert(name);
        const char* value = element_.Attribute(name);
        if (!value) return std::nullopt;
        return std::string(value);
    }

    std::string text(const char* name, const std::string& fallback) {
        return raw(name).value_or(fallback);
    }

    std::vector<double> numbers(const char* name, const std::string& value, std::size_t count) {
        std::vector<double> out;
        const char* p = value.c_str();
        while (true) {
            while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r' || *p == ',') ++p;
            if (!*p) break;
            char* end = nullptr;
            errno = 0;
            const double v = std::strtod(p, &end);
            if (end == p || errno == ERANGE || !std::isfinite(v)) {
                out.clear();
                break;
            }
            out.push_back(v);
            p = end;
        }
        if (out.size() != count)
            context_.fail(name, "expected " + std::string(count == 1 ? "a number" : std::to_string(count) + " numbers") +
                                    ", got '" + value + "'");
        return out;
    }

    double real(const char* name, double fallback) {
        const auto v = raw(name);
        return v ? numbers(name, *v, 1)[0] : fallback;
    }
    double requiredReal(const char* name) {
        const auto v = raw(name);
        if (!v) context_.fail(name, "missing required attribute");
        return numbers(name, *v, 1)[0];
    }
    cv::Vec3d vec3(const char* name, const cv::Vec3d& fallback, bool required = false) {
        const auto v = raw(name);
        if (!v) {
            if (required) context_.fail(name, "missing required attribute");
            return fallback;
        }
        const auto n = numbers(name, *v, 3);
        return {n[0], n[1], n[2]};
    }
    std::array<double, 3> array3(const char* name, const std::array<double, 3>& fallback,
                                 bool required = false) {
        const cv::Vec3d v = vec3(name, {fallback[0], fallback[1], fallback[2]}, required);
        return {v[0], v[1], v[2]};
    }
    cv::Vec2d vec2(const char* name, const cv::Vec2d& fallback) {
        const auto v = raw(name);
        if (!v) return fallback;
        const auto n = numbers(name, *v, 2);
        return {n[0], n[1]};
    }
    long long integer(const char* name, long long fallback, long long lo, long long hi) {
        const auto v = raw(name);
        if (!v) return fallback;
        char* end = nullptr;
        errno = 0;
        const long long x = std::strtoll(v->c_str(), &end, 10);
        if (v->empty() || *end != '\0' || errno == ERANGE || x < lo || x > hi)
            context_.fail(name, "expected an integer in [" + std::to_string(lo) + ", " +
                                    std::to_string(hi) + "], got '" + *v + "'");
        return x;
    }
    bool boolean(const char* name, bool fallback) {
        const auto v = raw(name);
        if (!v) return fallback;
        if (*v == "true" || *v == "1") return true;
        if (*v == "false" || *v == "0") return false;
        context_.fail(name, "expected true or false, got '" + *v + "'");
    }
    Shape shape(const char* name, bool required) {
        const auto v = raw(name);
        if (!v) {
            if (required) context_.fail(name, "missing required attribute (sphere, disc, duck or box)");
            return Shape::Sphere;
        }
        if (*v == "sphere") return Shape::Sphere;
        if (*v == "disc") return Shape::Disc;
        if (*v == "duck") return Shape::Duck;
        if (*v == "box") return Shape::Box;
        context_.fail(name, "expected sphere, disc, duck or box, got '" + *v + "'");
    }

    /// Rejects attributes that were never asked for.
    void finish() const {
        for (const tinyxml2::XMLAttribute* a = element_.FirstAttribute(); a; a = a->Next()) {
            if (!known_.count(a->Name())) {
                std::string list;
                for (const auto& k : known_) list += (list.empty() ? "" : ", ") + k;
                context_.fail(a->Name(), "unknown attribute (known: " + list + ")");
            }
        }
    }

private:
    const tinyxml2::XMLElement& element_;
    Context context_;
    std::set<std::string> known_;
};

void noChildren(const std::string& source, const tinyxml2::XMLElement& e, const std::string& path) {
    if (const auto* child = e.FirstChildElement())
        throw SceneError(source, child->GetLineNum(), path + "/" + child->Name(),
                         "unexpected element: <" + std::string(e.Name()) + "> has no child elements");
}

RigidTransform poseFrom(const std::array<double, 3>& om, const cv::Vec3d& t) {
    return makeRigidTransform(rodrigues(om), t);
}

Scene parseScene(const tinyxml2::XMLElement& root, const std::string& source) {
    Scene scene;
    if (std::string(root.Name()) != "scene")
        throw SceneError(source, root.GetLineNum(), "/" + std::string(root.Name()),
                         "the root element must be <scene>");
    {
        ElementReader r(source, root, "/scene");
        scene.name = r.text("name", "scene");
        r.finish();
    }
    std::map<std::string, int> counts;
    std::set<std::string> names;
    for (const auto* e = root.FirstChildElement(); e; e = e->NextSiblingElement()) {
        const std::string tag = e->Name();
        const int index = ++counts[tag];
        const std::string path = "/scene/" + tag + "[" + std::to_string(index) + "]";
        const bool single = tag != "target" && tag != "armMarker" && tag != "occluder";
        if (single && index > 1)
            throw SceneError(source, e->GetLineNum(), path, "<" + tag + "> may appear only once");
        ElementReader r(source, *e, "/scene/" + (single ? tag : path.substr(7)));
        const Context& c = r.context();
        if (tag == "seabed") {
            Seabed& s = scene.seabed;
            s.enabled = r.boolean("enabled", s.enabled);
            s.distanceMm = r.real("distanceMm", s.distanceMm);
            s.tiltDeg = r.real("tiltDeg", s.tiltDeg);
            s.albedo = r.array3("albedo", s.albedo);
            s.textureContrast = r.real("textureContrast", s.textureContrast);
            s.textureScaleMm = r.real("textureScaleMm", s.textureScaleMm);
            s.textureSeed = static_cast<std::uint64_t>(r.integer("textureSeed", 1, 0, 1LL << 62));
            r.finish();
            noChildren(source, *e, c.path);
            checkSeabed(c, s);
        } else if (tag == "lighting") {
            Lighting& l = scene.lighting;
            l.ambient = r.array3("ambient", l.ambient);
            l.lightIntensity = r.array3("lightIntensity", l.lightIntensity);
            l.lightPositionMm = r.vec3("lightPositionMm", l.lightPositionMm);
            l.inverseSquare = r.boolean("inverseSquare", l.inverseSquare);
            l.referenceDistanceMm = r.real("referenceDistanceMm", l.referenceDistanceMm);
            l.darknessFactor = r.real("darknessFactor", l.darknessFactor);
            r.finish();
            noChildren(source, *e, c.path);
            checkLighting(c, l);
        } else if (tag == "strobe") {
            Strobe& s = scene.lighting.strobe;
            s.enabled = r.boolean("enabled", true);
            s.centrePx = r.vec2("centrePx", s.centrePx);
            r.finish();
            std::set<std::string> seen;
            for (const auto* ch = e->FirstChildElement(); ch; ch = ch->NextSiblingElement()) {
                const std::string name = ch->Name();
                const std::size_t i = name == "red" ? 0 : name == "green" ? 1 : name == "blue" ? 2 : 3;
                if (i == 3 || !seen.insert(name).second)
                    throw SceneError(source, ch->GetLineNum(), c.path + "/" + name,
                                     i == 3 ? "unexpected element (expected red, green or blue)"
                                            : "<" + name + "> may appear only once");
                ElementReader cr(source, *ch, c.path + "/" + name);
                s.rgb[i].coefficient = cr.real("coefficient", 1.0);
                s.rgb[i].exponent = cr.real("exponent", 0.0);
                cr.finish();
                noChildren(source, *ch, cr.context().path);
                Strobe one;
                one.rgb[i] = s.rgb[i];
                checkStrobe(Context{source, ch->GetLineNum(), c.path}, one);
            }
            checkStrobe(c, s);
        } else if (tag == "water") {
            Lighting& l = scene.lighting;
            l.attenuationPerM = r.array3("attenuationPerM", l.attenuationPerM);
            l.background = r.array3("background", l.background);
            l.backscatter = r.array3("backscatter", l.backscatter);
            l.turbidityPerM = r.real("turbidityPerM", l.turbidityPerM);
            r.finish();
            noChildren(source, *e, c.path);
            checkWater(c, l);
        } else if (tag == "sensor") {
            SensorNoise& s = scene.sensor;
            s.exposure = r.real("exposure", s.exposure);
            s.readNoiseDn = r.real("readNoiseDn", s.readNoiseDn);
            s.shotNoise = r.boolean("shotNoise", s.shotNoise);
            s.fullWellElectrons = r.real("fullWellElectrons", s.fullWellElectrons);
            s.blackLevelDn = r.real("blackLevelDn", s.blackLevelDn);
            r.finish();
            noChildren(source, *e, c.path);
            checkSensor(c, s);
        } else if (tag == "registration") {
            // base_T_vision: a Rodrigues vector om or a row-major rotation matrix.
            const auto om = r.raw("om");
            const auto rotation = r.raw("rotation");
            const cv::Vec3d t = r.vec3("translationMm", {0, 0, 0}, true);
            r.finish();
            noChildren(source, *e, c.path);
            if (om.has_value() == rotation.has_value())
                c.fail("", "give exactly one of om (Rodrigues vector, rad) and rotation (9 numbers)");
            RigidTransform registration;
            if (om) {
                const auto v = r.numbers("om", *om, 3);
                registration = poseFrom({v[0], v[1], v[2]}, t);
            } else {
                const auto v = r.numbers("rotation", *rotation, 9);
                std::copy(v.begin(), v.end(), registration.rotation.begin());
                registration.translationMm = {t[0], t[1], t[2]};
                checkRotation(c, "rotation", registration);
            }
            scene.baseTVision = registration;
        } else if (tag == "target") {
            TargetSpec t;
            t.name = r.text("name", "target" + std::to_string(index));
            t.type = r.text("type", t.type);
            t.shape = r.shape("shape", true);
            t.centreMm = r.vec3("centreMm", t.centreMm, true);
            if (t.shape == Shape::Box) t.halfSizeMm = r.vec3("halfSizeMm", t.halfSizeMm, true);
            else t.radiusMm = r.requiredReal("radiusMm");
            if (t.shape == Shape::Disc) t.normal = r.vec3("normal", t.normal);
            if (t.shape == Shape::Duck || t.shape == Shape::Box) t.om = r.array3("om", t.om);
            t.albedo = r.array3("albedo", t.albedo, true);
            if (t.shape == Shape::Duck) t.beakAlbedo = r.array3("beakAlbedo", t.beakAlbedo);
            if (t.shape == Shape::Sphere || t.shape == Shape::Disc) {
                if (r.raw("secondAlbedo")) t.secondAlbedo = r.array3("secondAlbedo", {0, 0, 0}, true);
                t.splitNormal = r.vec3("splitNormal", t.splitNormal);
                t.splitOffsetMm = r.real("splitOffsetMm", t.splitOffsetMm);
            }
            r.finish();
            noChildren(source, *e, c.path);
            checkName(c, t.name, names);
            checkTarget(c, t);
            scene.targets.push_back(t);
        } else if (tag == "armMarker") {
            ArmMarker a;
            a.name = r.text("name", index == 1 ? "arm" : "arm" + std::to_string(index));
            a.type = r.text("type", a.type);
            a.positionBaseMm = r.vec3("positionBaseMm", a.positionBaseMm, true);
            a.omBase = r.array3("omBase", a.omBase);
            a.halfSizeMm = r.vec3("halfSizeMm", a.halfSizeMm);
            a.albedo = r.array3("albedo", a.albedo);
            r.finish();
            noChildren(source, *e, c.path);
            checkName(c, a.name, names);
            checkArmMarker(c, a);
            scene.armMarkers.push_back(a);
        } else if (tag == "occluder") {
            Occluder o;
            o.name = r.text("name", "occluder" + std::to_string(index));
            o.shape = r.shape("shape", false);
            o.centreMm = r.vec3("centreMm", o.centreMm, true);
            if (o.shape == Shape::Box) {
                o.halfSizeMm = r.vec3("halfSizeMm", o.halfSizeMm, true);
                o.om = r.array3("om", o.om);
            } else if (o.shape == Shape::Sphere) {
                o.radiusMm = r.requiredReal("radiusMm");
            }
            o.albedo = r.array3("albedo", o.albedo);
            r.finish();
            noChildren(source, *e, c.path);
            checkOccluder(c, o);
            scene.occluders.push_back(o);
        } else if (tag == "checkerboard") {
            Checkerboard b;
            b.squaresX = static_cast<int>(r.integer("squaresX", b.squaresX, 2, 100));
            b.squaresY = static_cast<int>(r.integer("squaresY", b.squaresY, 2, 100));
            b.squareMm = r.real("squareMm", b.squareMm);
            b.marginSquares = r.real("marginSquares", b.marginSquares);
            b.om = r.array3("om", b.om);
            b.positionMm = r.vec3("positionMm", b.positionMm, true);
            b.dark = r.array3("dark", b.dark);
            b.light = r.array3("light", b.light);
            r.finish();
            noChildren(source, *e, c.path);
            checkCheckerboard(c, b);
            scene.checkerboard = b;
        } else {
            throw SceneError(source, e->GetLineNum(), "/scene/" + tag,
                             "unknown element (expected seabed, lighting, strobe, water, sensor, "
                             "registration, target, armMarker, occluder or checkerboard)");
        }
    }
    if (scene.targets.size() + scene.armMarkers.size() > kMaxSceneTargets)
        throw SceneError(source, root.GetLineNum(), "/scene",
                         "at most " + std::to_string(kMaxSceneTargets) +
                             " targets and arm markers, got " +
                             std::to_string(scene.targets.size() + scene.armMarkers.size()));
    return scene;
}

}  // namespace

Scene readSceneString(const std::string& xml, const std::string& sourceName) {
    tinyxml2::XMLDocument doc;
    if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS)
        throw SceneError(sourceName, doc.ErrorLineNum(), "/", std::string("malformed XML: ") + doc.ErrorStr());
    const tinyxml2::XMLElement* root = doc.RootElement();
    if (!root) throw SceneError(sourceName, 0, "/", "the document has no root element");
    return parseScene(*root, sourceName);
}

Scene readSceneFile(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("cannot open scene file '" + path.string() + "'");
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw IoError("cannot read scene file '" + path.string() + "'");
    return readSceneString(text.str(), path.filename().string());
}

void validateScene(const Scene& scene) {
    const std::string src = "<memory>";
    checkSeabed({src, 0, "/scene/seabed"}, scene.seabed);
    checkLighting({src, 0, "/scene/lighting"}, scene.lighting);
    checkStrobe({src, 0, "/scene/strobe"}, scene.lighting.strobe);
    checkWater({src, 0, "/scene/water"}, scene.lighting);
    checkSensor({src, 0, "/scene/sensor"}, scene.sensor);
    if (scene.baseTVision) checkRotation({src, 0, "/scene/registration"}, "rotation", *scene.baseTVision);
    std::set<std::string> names;
    for (std::size_t i = 0; i < scene.targets.size(); ++i) {
        const Context c{src, 0, "/scene/target[" + std::to_string(i + 1) + "]"};
        checkName(c, scene.targets[i].name, names);
        checkTarget(c, scene.targets[i]);
    }
    for (std::size_t i = 0; i < scene.armMarkers.size(); ++i) {
        const Context c{src, 0, "/scene/armMarker[" + std::to_string(i + 1) + "]"};
        checkName(c, scene.armMarkers[i].name, names);
        checkArmMarker(c, scene.armMarkers[i]);
    }
    for (std::size_t i = 0; i < scene.occluders.size(); ++i)
        checkOccluder({src, 0, "/scene/occluder[" + std::to_string(i + 1) + "]"}, scene.occluders[i]);
    if (scene.checkerboard) checkCheckerboard({src, 0, "/scene/checkerboard"}, *scene.checkerboard);
    if (scene.targets.size() + scene.armMarkers.size() > kMaxSceneTargets)
        throw SceneError(src, 0, "/scene", "at most " + std::to_string(kMaxSceneTargets) +
                                               " targets and arm markers");
}

}  // namespace avatar::render
