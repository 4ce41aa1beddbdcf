// The scene file format written (docs/tools/avatar-render.md): writeSceneString()
// and writeSceneFile(); the reader and the checks are in Scene.cpp.
#include <avatar/render/Scene.h>

#include <avatar/common/Error.h>
#include <avatar/common/internal/Text.h>

#include <fstream>
#include <sstream>
#include <string>

namespace avatar::render {

namespace {

using text::formatDouble;
using text::formatDoubles;

class Writer {
public:
    explicit Writer(std::ostringstream& out) : out_(out) {}
    Writer& open(const char* tag) {
        out_ << "  <" << tag;
        return *this;
    }
    Writer& attr(const char* name, const std::string& value) {
        out_ << ' ' << name << "=\"" << escape(value) << '"';
        return *this;
    }
    Writer& attr(const char* name, double v) { return attr(name, formatDouble(v)); }
    Writer& attr(const char* name, bool v) { return attr(name, std::string(v ? "true" : "false")); }
    Writer& attr(const char* name, const cv::Vec3d& v) { return attr(name, formatDoubles(v, 3)); }
    Writer& attr(const char* name, const std::array<double, 3>& v) { return attr(name, formatDoubles(v, 3)); }
    void close() { out_ << "/>\n"; }

    static std::string escape(const std::string& s) {
        std::string out;
        for (char ch : s) {
            switch (ch) {
                case '&': out += "&amp;"; break;
                case '<': out += "&lt;"; break;
                case '>': out += "&gt;"; break;
                case '"': out += "&quot;"; break;
                default: out += ch;
            }
        }
        return out;
    }

private:
    std::ostringstream& out_;
};

}  // namespace

std::string writeSceneString(const Scene& scene) {
    validateScene(scene);
    std::ostringstream out;
    Writer w(out);
    out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<scene name=\"" << Writer::escape(scene.name) << "\">\n";
    const Seabed& s = scene.seabed;
    w.open("seabed").attr("enabled", s.enabled).attr("distanceMm", s.distanceMm).attr("tiltDeg", s.tiltDeg)
        .attr("albedo", s.albedo).attr("textureContrast", s.textureContrast)
        .attr("textureScaleMm", s.textureScaleMm).attr("textureSeed", std::to_string(s.textureSeed)).close();
    const Lighting& l = scene.lighting;
    w.open("lighting").attr("ambient", l.ambient).attr("lightIntensity", l.lightIntensity)
        .attr("lightPositionMm", l.lightPositionMm).attr("inverseSquare", l.inverseSquare)
        .attr("referenceDistanceMm", l.referenceDistanceMm).attr("darknessFactor", l.darknessFactor).close();
    out << "  <strobe enabled=\"" << (l.strobe.enabled ? "true" : "false") << "\" centrePx=\""
        << formatDoubles(l.strobe.centrePx, 2) << "\">\n";
    static const char* const channels[3] = {"red", "green", "blue"};
    for (std::size_t i = 0; i < 3; ++i)
        out << "    <" << channels[i] << " coefficient=\"" << formatDouble(l.strobe.rgb[i].coefficient)
            << "\" exponent=\"" << formatDouble(l.strobe.rgb[i].exponent) << "\"/>\n";
    out << "  </strobe>\n";
    w.open("water").attr("attenuationPerM", l.attenuationPerM).attr("background", l.background)
        .attr("backscatter", l.backscatter).attr("turbidityPerM", l.turbidityPerM).close();
    const SensorNoise& n = scene.sensor;
    w.open("sensor").attr("exposure", n.exposure).attr("readNoiseDn", n.readNoiseDn)
        .attr("shotNoise", n.shotNoise).attr("fullWellElectrons", n.fullWellElectrons)
        .attr("blackLevelDn", n.blackLevelDn).close();
    if (scene.baseTVision) {
        const auto& r = scene.baseTVision->rotation;
        std::string rotation;
        for (double x : r) rotation += (rotation.empty() ? "" : " ") + formatDouble(x);
        w.open("registration").attr("rotation", rotation)
            .attr("translationMm", scene.baseTVision->translationMm).close();
    }
    for (const TargetSpec& t : scene.targets) {
        w.open("target").attr("name", t.name).attr("type", t.type)
            .attr("shape", std::string(toString(t.shape))).attr("centreMm", t.centreMm);
        if (t.shape == Shape::Box) w.attr("halfSizeMm", t.halfSizeMm);
        else w.attr("radiusMm", t.radiusMm);
        if (t.shape == Shape::Disc) w.attr("normal", t.normal);
        if (t.shape == Shape::Duck || t.shape == Shape::Box) w.attr("om", t.om);
        w.attr("albedo", t.albedo);
        if (t.shape == Shape::Duck) w.attr("beakAlbedo", t.beakAlbedo);
        if (t.secondAlbedo)
            w.attr("secondAlbedo", *t.secondAlbedo).attr("splitNormal", t.splitNormal).attr("splitOffsetMm", t.splitOffsetMm);
        w.close();
    }
    for (const ArmMarker& a : scene.armMarkers)
        w.open("armMarker").attr("name", a.name).attr("type", a.type).attr("positionBaseMm", a.positionBaseMm)
            .attr("omBase", a.omBase).attr("halfSizeMm", a.halfSizeMm).attr("albedo", a.albedo).close();
    for (const Occluder& o : scene.occluders) {
        w.open("occluder").attr("name", o.name).attr("shape", std::string(toString(o.shape)))
            .attr("centreMm", o.centreMm);
        if (o.shape == Shape::Box) w.attr("halfSizeMm", o.halfSizeMm).attr("om", o.om);
        else w.attr("radiusMm", o.radiusMm);
        w.attr("albedo", o.albedo).close();
    }
    if (scene.checkerboard) {
        const Checkerboard& b = *scene.checkerboard;
        w.open("checkerboard").attr("squaresX", std::to_string(b.squaresX))
            .attr("squaresY", std::to_string(b.squaresY)).attr("squareMm", b.squareMm)
            .attr("marginSquares", b.marginSquares)
            .attr("om", b.om).attr("positionMm", b.positionMm).attr("dark", b.dark).attr("light", b.light)
            .close();
    }
    out << "</scene>\n";
    return out.str();
}

void writeSceneFile(const Scene& scene, const std::filesystem::path& path) {
    const std::string text = writeSceneString(scene);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out || !(out << text) || !out.flush())
        throw IoError("cannot write scene file '" + path.string() + "'");
}

}  // namespace avatar::render
