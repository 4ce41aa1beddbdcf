#include "ConfigWriter.h"

#include "ConfigText.h"

#include <tinyxml2.h>

#include <array>
#include <cstddef>
#include <string_view>

namespace avatar::config_internal {

namespace {

/// Streams elements through tinyxml2's printer, which escapes text and attributes.
class Writer {
public:
    Writer() : printer_(nullptr, /*compact=*/false) {}

    void open(const char* name) { printer_.OpenElement(name); }
    void attribute(const char* name, const std::string& value) { printer_.PushAttribute(name, value.c_str()); }
    void close() { printer_.CloseElement(); }
    void comment(const char* text) { printer_.PushComment(text); }
    void declaration() { printer_.PushDeclaration("xml version=\"1.0\" encoding=\"UTF-8\""); }

    void text(const char* name, std::string_view value) {
        open(name);
        printer_.PushText(std::string(value).c_str());
        close();
    }
    void number(const char* name, double value) { text(name, formatDouble(value)); }
    void integer(const char* name, int value) { text(name, std::to_string(value)); }
    void boolean(const char* name, bool value) { text(name, value ? "true" : "false"); }

    template <std::size_t N>
    void vector(const char* name, const std::array<double, N>& values) {
        text(name, text::formatDoubles(values, N));
    }

    void range(const char* name, const Range& r) {
        open(name);
        number("min", r.min);
        number("max", r.max);
        close();
    }

    std::string str() const { return std::string(printer_.CStr(), printer_.CStrSize() - 1); }

private:
    tinyxml2::XMLPrinter printer_;
};

void writeFeature(Writer& w, const char* name, const CameraFeature& f) {
    w.open(name);
    w.number("value", f.value);
    w.boolean("auto", f.automatic);
    w.close();
}

void writeCamera(Writer& w, const CameraHardwareConfig& c) {
    w.open("camera");
    w.integer("width", c.width);
    w.integer("height", c.height);
    w.integer("bitDepth", c.bitDepth);
    w.integer("channels", c.channels);
    w.boolean("bayer", c.bayer);
    w.text("bayerPattern", enumWord(c.bayerPattern).value_or("?"));
    w.boolean("endianSwap", c.endianSwap);
    w.text("leftCameraId", c.leftCameraId);
    w.text("rightCameraId", c.rightCameraId);
    w.open("features");
    writeFeature(w, "exposure", c.features.exposure);
    writeFeature(w, "shutter", c.features.shutter);
    writeFeature(w, "gain", c.features.gain);
    w.open("whiteBalance");
    w.number("blueU", c.features.whiteBalance.blueU);
    w.number("redV", c.features.whiteBalance.redV);
    w.boolean("auto", c.features.whiteBalance.automatic);
    w.close();
    writeFeature(w, "brightness", c.features.brightness);
    writeFeature(w, "gamma", c.features.gamma);
    w.close();
    w.close();
}

void writeTarget(Writer& w, const TargetType& t) {
    w.open("target");
    w.attribute("name", t.name);
    w.text("filter", enumWord(t.filter).value_or("?"));
    w.range("redGreen", t.redGreen);
    w.range("redBlue", t.redBlue);
    w.range("blueGreen", t.blueGreen);
    if (t.brightness) {
        w.range("brightness", *t.brightness);
    }
    if (!t.brightnessBands.empty()) {
        w.open("brightnessBands");
        for (const BrightnessBand& b : t.brightnessBands) {
            w.open("band");
            w.range("brightness", b.brightness);
            w.range("redGreen", b.redGreen);
            w.range("redBlue", b.redBlue);
            w.range("blueGreen", b.blueGreen);
            w.close();
        }
        w.close();
    }
    if (t.veil) {
        w.open("veil");
        w.vector("colourRgb", t.veil->colourRgb);
        w.number("maxShare", t.veil->maxShare);
        if (t.veil->redGreen) w.range("redGreen", *t.veil->redGreen);
        if (t.veil->blueGreen) w.range("blueGreen", *t.veil->blueGreen);
        w.close();
    }
    if (t.water) {
        w.open("water");
        w.vector("attenuationPerM", t.water->attenuationPerM);
        w.number("maxPathM", t.water->maxPathM);
        if (t.water->redGreen) w.range("redGreen", *t.water->redGreen);
        if (t.water->blueGreen) w.range("blueGreen", *t.water->blueGreen);
        w.close();
    }
    w.open("hsv");
    w.range("hue", t.hsv.hue);
    w.range("saturation", t.hsv.saturation);
    w.range("value", t.hsv.value);
    w.close();
    w.boolean("erodeRestore", t.erodeRestore);
    w.integer("erodeKernelSize", t.erodeKernelSize);
    w.range("area", t.area);
    w.range("aspectRatio", t.aspectRatio);
    w.range("areaRatio", t.areaRatio);
    w.open("window");
    w.integer("x", t.window.x);
    w.integer("y", t.window.y);
    w.integer("width", t.window.width);
    w.integer("height", t.window.height);
    w.close();
    w.text("shape", enumWord(t.shape).value_or("?"));
    if (t.sizeMm) {
        w.range("sizeMm", *t.sizeMm);
    }
    w.close();
}

void writeMatch(Writer& w, const MatchConfig& m) {
    w.open("match");
    w.text("method", enumWord(m.method).value_or("?"));
    w.open("box");
    w.range("dx", Range{m.boxDxMin, m.boxDxMax});
    w.range("dy", Range{m.boxDyMin, m.boxDyMax});
    w.close();
    w.open("epipolarLine");
    w.number("maxDistancePx", m.maxEpipolarDistancePx);
    w.range("rangeMm", Range{m.minRangeMm, m.maxRangeMm});
    w.close();
    w.open("shape");
    w.number("magnitudeWeight", m.shape.magnitudeWeight);
    w.number("directionWeight", m.shape.directionWeight);
    w.number("maxError", m.shape.maxError);
    w.number("maxAreaRatio", m.shape.maxAreaRatio);
    w.close();
    w.text("repeats", enumWord(m.repeats).value_or("?"));
    w.close();
}

void writeIntrinsics(Writer& w, const char* name, const CameraIntrinsics& in) {
    w.open(name);
    w.vector("fc", in.fc);
    w.vector("cc", in.cc);
    w.number("alphaC", in.alphaC);
    w.vector("kc", in.kc);
    w.close();
}

void writeStereo(Writer& w, const StereoSystemConfig& s) {
    w.open("stereo");
    writeIntrinsics(w, "left", s.left);
    writeIntrinsics(w, "right", s.right);
    w.vector("om", s.om);
    w.vector("translationMm", s.translationMm);
    if (s.baseTVision) {
        w.open("baseTVision");
        w.vector("rotation", s.baseTVision->rotation);
        w.vector("translationMm", s.baseTVision->translationMm);
        w.close();
    }
    if (s.uncertainty) {
        w.open("uncertainty");
        for (const auto& [name, u] : {std::pair<const char*, const IntrinsicsUncertainty&>{"left", s.uncertainty->left},
                                      {"right", s.uncertainty->right}}) {
            w.open(name);
            w.vector("fc", u.fc);
            w.vector("cc", u.cc);
            w.number("alphaC", u.alphaC);
            w.vector("kc", u.kc);
            w.close();
        }
        w.vector("om", s.uncertainty->om);
        w.vector("translationMm", s.uncertainty->translationMm);
        w.close();
    }
    w.close();
}

void writeFalloff(Writer& w, const char* name, const FalloffChannel& f) {
    w.open(name);
    w.number("coefficient", f.coefficient);
    w.number("exponent", f.exponent);
    w.close();
}

void writeLighting(Writer& w, const LightingConfig& l) {
    w.open("lighting");
    w.open("frameAverage");
    w.boolean("enabled", l.frameAverageEnabled);
    w.vector("gainsRgb", l.gainsRgb);
    w.close();
    w.open("pattern");
    w.boolean("enabled", l.patternEnabled);
    w.vector("centrePx", l.patternCentrePx);
    writeFalloff(w, "red", l.red);
    writeFalloff(w, "green", l.green);
    writeFalloff(w, "blue", l.blue);
    if (!l.templateImagePath.empty()) {
        w.text("templateImage", l.templateImagePath);
    }
    w.close();
    w.close();
}

void writeAnalysis(Writer& w, const AnalysisConfig& a) {
    w.open("analysis");
    std::string stages;
    for (const std::string& stage : a.stages) {
        stages += (stages.empty() ? "" : " ") + stage;
    }
    w.text("stages", stages);
    w.text("demosaic", enumWord(a.demosaic).value_or("?"));
    w.text("centroid", enumWord(a.centroid).value_or("?"));
    w.text("triangulation", enumWord(a.triangulation).value_or("?"));
    w.open("visibility");
    w.number("minContrast", a.visibility.minContrast);
    w.number("maxSaturatedFraction", a.visibility.maxSaturatedFraction);
    w.number("maxHaze", a.visibility.maxHaze);
    w.close();
    w.open("tracking");
    w.boolean("enabled", a.tracking.enabled);
    w.integer("fullFrameEvery", a.tracking.fullFrameEvery);
    w.integer("marginPx", a.tracking.marginPx);
    w.close();
    w.open("coarseToFine");
    w.boolean("enabled", a.coarseToFine.enabled);
    w.integer("marginPx", a.coarseToFine.marginPx);
    w.close();
    w.integer("threads", a.threads);
    w.close();
}

void writeServo(Writer& w, const ServoConfig& c) {
    w.open("servo");
    w.text("sampleType", c.sampleType);
    w.text("armType", c.armType);
    w.text("mode", enumWord(c.mode).value_or("?"));
    w.text("filter", enumWord(c.filter).value_or("?"));
    w.number("maxMoveMm", c.maxMoveMm);
    w.number("finalDistanceMm", c.finalDistanceMm);
    w.vector("toolOffsetMm", c.toolOffsetMm);
    w.number("armToleranceMm", c.armToleranceMm);
    w.number("armDriftMm", c.armDriftMm);
    w.number("armDriftPerMm", c.armDriftPerMm);
    w.number("maxTargetJumpMm", c.maxTargetJumpMm);
    w.number("trackingRadiusMm", c.trackingRadiusMm);
    w.integer("visionTimeoutMs", c.visionTimeoutMs);
    w.integer("moveTimeoutMs", c.moveTimeoutMs);
    w.integer("lostTimeoutMs", c.lostTimeoutMs);
    w.integer("maxIterations", c.maxIterations);
    w.boolean("refineRegistration", c.refineRegistration);
    w.number("probeAngleDeg", c.probeAngleDeg);
    w.number("registrationStdDeg", c.registrationStdDeg);
    w.open("kalman");
    w.number("sampleNoiseMm", c.kalmanSampleNoiseMm);
    w.number("armNoisePerMm", c.kalmanArmNoisePerMm);
    w.number("defaultSigmaMm", c.kalmanDefaultSigmaMm);
    w.close();
    w.close();
}

}  // namespace

std::string formatTarget(const TargetType& type) {
    Writer w;
    writeTarget(w, type);
    return w.str() + "\n";
}

std::string formatDocument(const AvatarConfig& config) {
    Writer w;
    w.declaration();
    w.comment(" AVATAR configuration; the schema is described in docs/config.md ");
    w.open("avatar");
    w.attribute("version", "1");
    writeCamera(w, config.camera);
    w.open("targets");
    for (const TargetType& t : config.targets.targets) {
        writeTarget(w, t);
    }
    w.close();
    writeMatch(w, config.match);
    writeStereo(w, config.stereo);
    writeLighting(w, config.lighting);
    writeAnalysis(w, config.analysis);
    if (config.servo) {
        writeServo(w, *config.servo);
    }
    w.close();
    return w.str() + "\n";
}

}  // namespace avatar::config_internal
