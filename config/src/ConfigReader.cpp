// Over 600 lines on purpose: the generic element reader (line numbers, unknown
// and repeated elements) and one function per element of the schema in
// docs/config.md, top down, so the whole schema is read in one place.
#include "ConfigReader.h"

#include "ConfigText.h"

#include <avatar/config/ConfigXml.h>

#include <tinyxml2.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <initializer_list>
#include <map>
#include <optional>
#include <string_view>
#include <system_error>
#include <vector>

namespace avatar::config_internal {

namespace {

using tinyxml2::XMLAttribute;
using tinyxml2::XMLDocument;
using tinyxml2::XMLElement;
using tinyxml2::XMLNode;
using tinyxml2::XMLText;

constexpr std::string_view kXmlSpace = " \t\r\n";
constexpr std::size_t kMaxQuoted = 40;

std::string_view trim(std::string_view s) {
    const std::size_t first = s.find_first_not_of(kXmlSpace);
    if (first == std::string_view::npos) {
        return {};
    }
    const std::size_t last = s.find_last_not_of(kXmlSpace);
    return s.substr(first, last - first + 1);
}

/// 'text', shortened to kMaxQuoted characters.
std::string quote(std::string_view text) {
    if (text.size() > kMaxQuoted) {
        return "'" + std::string(text.substr(0, kMaxQuoted)) + "...'";
    }
    return "'" + std::string(text) + "'";
}

std::string element(std::string_view name) {
    return "<" + std::string(name) + ">";
}

/// A readable account of a tinyxml2 parse error.
std::string malformedMessage(const XMLDocument& doc) {
    std::string what;
    switch (doc.ErrorID()) {
        case tinyxml2::XML_ERROR_PARSING_ELEMENT: what = "cannot parse an element"; break;
        case tinyxml2::XML_ERROR_PARSING_ATTRIBUTE: what = "cannot parse an attribute"; break;
        case tinyxml2::XML_ERROR_PARSING_TEXT: what = "cannot parse text"; break;
        case tinyxml2::XML_ERROR_PARSING_CDATA: what = "cannot parse a CDATA section"; break;
        case tinyxml2::XML_ERROR_PARSING_COMMENT: what = "cannot parse a comment"; break;
        case tinyxml2::XML_ERROR_PARSING_DECLARATION: what = "cannot parse a declaration"; break;
        case tinyxml2::XML_ERROR_PARSING_UNKNOWN: what = "cannot parse a <!...> node"; break;
        case tinyxml2::XML_ERROR_EMPTY_DOCUMENT: what = "the document has no element"; break;
        case tinyxml2::XML_ERROR_MISMATCHED_ELEMENT: what = "mismatched end tag"; break;
        case tinyxml2::XML_ELEMENT_DEPTH_EXCEEDED: what = "elements nested too deeply"; break;
        default: what = "parse error"; break;
    }
    // tinyxml2 appends the element it was in to ErrorStr(): "...: XMLElement name=camera".
    const std::string_view detail = doc.ErrorStr();
    constexpr std::string_view kNameTag = "XMLElement name=";
    if (const std::size_t at = detail.find(kNameTag); at != std::string_view::npos) {
        what += " in element " + element(trim(detail.substr(at + kNameTag.size())));
    }
    return "malformed XML: " + what + " (" + doc.ErrorName() + ")";
}

class Reader {
public:
    Reader(const std::string& source, LineMap& lines) : source_(source), lines_(lines) {}

    [[noreturn]] void fail(int line, const std::string& path, const std::string& problem) const {
        throw ConfigError(source_, line, path, problem);
    }

    void record(const std::string& path, int line) { lines_.emplace(path, line); }

    /// Only the attributes in @p allowed may appear.
    void checkAttributes(const XMLElement* el, const std::string& path,
                         std::initializer_list<std::string_view> allowed) const {
        for (const XMLAttribute* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
            bool known = false;
            for (std::string_view name : allowed) {
                known = known || name == a->Name();
            }
            if (!known) {
                fail(el->GetLineNum(), path + "/@" + a->Name(), "unknown attribute '" + std::string(a->Name()) + "'");
            }
        }
    }

    /// The trimmed text of an element that holds a value (no attributes, no
    /// child elements; comments are allowed).
    std::string leafText(const XMLElement* el, const std::string& path) {
        record(path, el->GetLineNum());
        checkAttributes(el, path, {});
        std::string text;
        for (const XMLNode* n = el->FirstChild(); n != nullptr; n = n->NextSibling()) {
            if (const XMLElement* child = n->ToElement()) {
                fail(child->GetLineNum(), path + "/" + child->Name(), "unknown element " + element(child->Name()));
            }
            if (const XMLText* t = n->ToText()) {
                text += t->Value();
            }
        }
        return std::string(trim(text));
    }

    int readInt(const XMLElement* el, const std::string& path) {
        const std::string text = leafText(el, path);
        int value = 0;
        const char* end = text.data() + text.size();
        const auto [ptr, ec] = std::from_chars(text.data(), end, value);
        if (ec == std::errc::result_out_of_range) {
            fail(el->GetLineNum(), path, "integer out of range, got " + quote(text));
        }
        if (ec != std::errc() || ptr != end) {
            fail(el->GetLineNum(), path, "expected an integer, got " + quote(text));
        }
        return value;
    }

    double parseDouble(std::string_view token, int line, const std::string& path) const {
        double value = 0.0;
        const char* end = token.data() + token.size();
        const auto [ptr, ec] = std::from_chars(token.data(), end, value);
        if (ec == std::errc::result_out_of_range) {
            fail(line, path, "number out of range, got " + quote(token));
        }
        if (ec != std::errc() || ptr != end) {
            fail(line, path, "expected a number, got " + quote(token));
        }
        if (!std::isfinite(value)) {
            fail(line, path, "expected a finite number, got " + quote(token));
        }
        return value;
    }

    double readDouble(const XMLElement* el, const std::string& path) {
        return parseDouble(leafText(el, path), el->GetLineNum(), path);
    }

    /// Exactly N numbers separated by white space.
    template <std::size_t N>
    std::array<double, N> readVector(const XMLElement* el, const std::string& path) {
        const std::vector<std::string> tokens = readWords(el, path);
        if (tokens.size() != N) {
            fail(el->GetLineNum(), path,
                 "expected " + std::to_string(N) + " numbers, got " + std::to_string(tokens.size()));
        }
        std::array<double, N> values{};
        for (std::size_t i = 0; i < N; ++i) {
            values[i] = parseDouble(tokens[i], el->GetLineNum(), path);
        }
        return values;
    }

    bool readBool(const XMLElement* el, const std::string& path) {
        const std::string text = leafText(el, path);
        if (text == "true") {
            return true;
        }
        if (text == "false") {
            return false;
        }
        fail(el->GetLineNum(), path, "expected true or false, got " + quote(text));
    }

    std::string readString(const XMLElement* el, const std::string& path) { return leafText(el, path); }

    template <typename Enum>
    Enum readEnum(const XMLElement* el, const std::string& path) {
        const std::string text = leafText(el, path);
        if (const std::optional<Enum> value = parseEnumWord<Enum>(text)) {
            return *value;
        }
        fail(el->GetLineNum(), path, std::string("expected ") + EnumWords<Enum>::list + ", got " + quote(text));
    }

    /// Words separated by white space.
    std::vector<std::string> readWords(const XMLElement* el, const std::string& path) {
        const std::string text = leafText(el, path);
        std::vector<std::string> words;
        std::string_view rest = text;
        while (!(rest = trim(rest)).empty()) {
            const std::size_t end = std::min(rest.find_first_of(kXmlSpace), rest.size());
            words.emplace_back(rest.substr(0, end));
            rest.remove_prefix(end);
        }
        return words;
    }

private:
    const std::string& source_;
    LineMap& lines_;
};

/// An element made of child elements, each allowed at most once, in any order.
class Section {
public:
    Section(Reader& reader, const XMLElement* el, std::string path, std::initializer_list<std::string_view> children,
            std::initializer_list<std::string_view> attributes = {})
        : reader_(reader), el_(el), path_(std::move(path)) {
        reader_.record(path_, el_->GetLineNum());
        reader_.checkAttributes(el_, path_, attributes);
        for (const XMLNode* n = el_->FirstChild(); n != nullptr; n = n->NextSibling()) {
            if (const XMLText* t = n->ToText()) {
                if (!trim(t->Value()).empty()) {
                    reader_.fail(t->GetLineNum(), path_, "unexpected text " + quote(trim(t->Value())));
                }
                continue;
            }
            const XMLElement* child = n->ToElement();
            if (child == nullptr) {
                continue;  // comments
            }
            const std::string_view name = child->Name();
            bool known = false;
            for (std::string_view allowed : children) {
                known = known || allowed == name;
            }
            if (!known) {
                reader_.fail(child->GetLineNum(), childPath(name), "unknown element " + element(name));
            }
            const auto [it, inserted] = found_.emplace(std::string(name), child);
            if (!inserted) {
                reader_.fail(child->GetLineNum(), childPath(name),
                             "duplicate element " + element(name) + " (first at line " +
                                 std::to_string(it->second->GetLineNum()) + ")");
            }
        }
    }

    const std::string& path() const { return path_; }
    int line() const { return el_->GetLineNum(); }
    std::string childPath(std::string_view name) const { return path_ + "/" + std::string(name); }
    bool has(std::string_view name) const { return found_.count(std::string(name)) != 0; }

    const XMLElement* find(std::string_view name) const {
        const auto it = found_.find(std::string(name));
        return it == found_.end() ? nullptr : it->second;
    }

    /// @p why explains a conditional requirement, e.g. "required when <bayer> is true".
    const XMLElement* require(std::string_view name, std::string_view why = {}) const {
        if (const XMLElement* el = find(name)) {
            return el;
        }
        std::string problem = "missing required element " + element(name);
        if (!why.empty()) {
            problem = "missing element " + element(name) + " (" + std::string(why) + ")";
        }
        reader_.fail(line(), path_, problem);
    }

    /// Reads a required child with @p read(reader, element, path).
    template <typename Read>
    auto get(std::string_view name, Read read, std::string_view why = {}) const {
        return read(reader_, require(name, why), childPath(name));
    }

    /// Reads an optional child into @p out; leaves @p out alone when absent.
    template <typename T, typename Read>
    void getOptional(std::string_view name, T& out, Read read) const {
        if (const XMLElement* el = find(name)) {
            out = read(reader_, el, childPath(name));
        }
    }

    /// Required when @p required, optional otherwise.
    template <typename T, typename Read>
    void getIf(bool required, std::string_view name, T& out, Read read, std::string_view why) const {
        if (required) {
            out = get(name, read, why);
        } else {
            getOptional(name, out, read);
        }
    }

private:
    Reader& reader_;
    const XMLElement* el_;
    std::string path_;
    std::map<std::string, const XMLElement*> found_;
};

// Readers of one value or section, all with the signature (Reader&, element, path).

int readInt(Reader& r, const XMLElement* el, const std::string& path) {
    return r.readInt(el, path);
}
double readDouble(Reader& r, const XMLElement* el, const std::string& path) {
    return r.readDouble(el, path);
}
bool readBool(Reader& r, const XMLElement* el, const std::string& path) {
    return r.readBool(el, path);
}
std::string readString(Reader& r, const XMLElement* el, const std::string& path) {
    return r.readString(el, path);
}
std::array<double, 2> readVector2(Reader& r, const XMLElement* el, const std::string& path) {
    return r.readVector<2>(el, path);
}
std::array<double, 3> readVector3(Reader& r, const XMLElement* el, const std::string& path) {
    return r.readVector<3>(el, path);
}
std::array<double, 5> readVector5(Reader& r, const XMLElement* el, const std::string& path) {
    return r.readVector<5>(el, path);
}
std::array<double, 9> readVector9(Reader& r, const XMLElement* el, const std::string& path) {
    return r.readVector<9>(el, path);
}
std::vector<std::string> readWords(Reader& r, const XMLElement* el, const std::string& path) {
    return r.readWords(el, path);
}
template <typename Enum>
Enum readEnum(Reader& r, const XMLElement* el, const std::string& path) {
    return r.readEnum<Enum>(el, path);
}

/// <min>..</min><max>..</max>, both required.
Range readRange(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"min", "max"});
    return Range{s.get("min", readDouble), s.get("max", readDouble)};
}

CameraFeature readFeature(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"value", "auto"});
    CameraFeature f;
    f.value = s.get("value", readDouble);
    s.getOptional("auto", f.automatic, readBool);
    return f;
}

WhiteBalance readWhiteBalance(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"blueU", "redV", "auto"});
    WhiteBalance wb;
    wb.blueU = s.get("blueU", readDouble);
    wb.redV = s.get("redV", readDouble);
    s.getOptional("auto", wb.automatic, readBool);
    return wb;
}

CameraFeatureSet readFeatures(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"exposure", "shutter", "gain", "whiteBalance", "brightness", "gamma"});
    CameraFeatureSet f;
    s.getOptional("exposure", f.exposure, readFeature);
    s.getOptional("shutter", f.shutter, readFeature);
    s.getOptional("gain", f.gain, readFeature);
    s.getOptional("whiteBalance", f.whiteBalance, readWhiteBalance);
    s.getOptional("brightness", f.brightness, readFeature);
    s.getOptional("gamma", f.gamma, readFeature);
    return f;
}

CameraHardwareConfig readCamera(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path,
                    {"width", "height", "bitDepth", "channels", "bayer", "bayerPattern", "endianSwap",
                     "leftCameraId", "rightCameraId", "features"});
    CameraHardwareConfig c;
    c.width = s.get("width", readInt);
    c.height = s.get("height", readInt);
    c.bitDepth = s.get("bitDepth", readInt);
    c.channels = s.get("channels", readInt);
    c.bayer = s.get("bayer", readBool);
    s.getIf(c.bayer, "bayerPattern", c.bayerPattern, readEnum<BayerPattern>, "required when <bayer> is true");
    s.getOptional("endianSwap", c.endianSwap, readBool);
    s.getOptional("leftCameraId", c.leftCameraId, readString);
    s.getOptional("rightCameraId", c.rightCameraId, readString);
    s.getOptional("features", c.features, readFeatures);
    return c;
}

HsvRanges readHsv(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"hue", "saturation", "value"});
    return HsvRanges{s.get("hue", readRange), s.get("saturation", readRange), s.get("value", readRange)};
}

SearchWindow readWindow(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"x", "y", "width", "height"});
    return SearchWindow{s.get("x", readInt), s.get("y", readInt), s.get("width", readInt), s.get("height", readInt)};
}

BrightnessBand readBand(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"brightness", "redGreen", "redBlue", "blueGreen"});
    return BrightnessBand{s.get("brightness", readRange), s.get("redGreen", readRange), s.get("redBlue", readRange),
                          s.get("blueGreen", readRange)};
}

/// Elements that hold only repeated <@p item> children, addressed item[1], item[2], ...
template <typename T, typename Read>
std::vector<T> readList(Reader& r, const XMLElement* el, const std::string& path, std::string_view item, Read read) {
    r.record(path, el->GetLineNum());
    r.checkAttributes(el, path, {});
    std::vector<T> out;
    for (const XMLNode* n = el->FirstChild(); n != nullptr; n = n->NextSibling()) {
        if (const XMLText* t = n->ToText()) {
            if (!trim(t->Value()).empty()) {
                r.fail(t->GetLineNum(), path, "unexpected text " + quote(trim(t->Value())));
            }
            continue;
        }
        const XMLElement* child = n->ToElement();
        if (child == nullptr) {
            continue;
        }
        if (std::string_view(child->Name()) != item) {
            r.fail(child->GetLineNum(), path + "/" + child->Name(), "unknown element " + element(child->Name()));
        }
        out.push_back(read(r, child, path + "/" + std::string(item) + "[" + std::to_string(out.size() + 1) + "]"));
    }
    return out;
}

Veil readVeil(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"colourRgb", "maxShare", "redGreen", "blueGreen"});
    Veil v{s.get("colourRgb", readVector3), s.get("maxShare", readDouble), std::nullopt, std::nullopt};
    if (s.has("redGreen")) v.redGreen = s.get("redGreen", readRange);
    if (s.has("blueGreen")) v.blueGreen = s.get("blueGreen", readRange);
    return v;
}

Water readWater(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"attenuationPerM", "maxPathM", "redGreen", "blueGreen"});
    Water w{s.get("attenuationPerM", readVector3), s.get("maxPathM", readDouble), std::nullopt, std::nullopt};
    if (s.has("redGreen")) w.redGreen = s.get("redGreen", readRange);
    if (s.has("blueGreen")) w.blueGreen = s.get("blueGreen", readRange);
    return w;
}

std::vector<BrightnessBand> readBands(Reader& r, const XMLElement* el, const std::string& path) {
    return readList<BrightnessBand>(r, el, path, "band", readBand);
}

TargetType readTarget(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path,
                    {"filter", "redGreen", "redBlue", "blueGreen", "brightness", "brightnessBands", "veil", "water",
                     "hsv", "erodeRestore",
                     "erodeKernelSize", "area", "aspectRatio", "areaRatio", "window", "shape", "sizeMm"},
                    {"name"});
    TargetType t;
    const char* name = el->Attribute("name");
    if (name == nullptr) {
        r.fail(el->GetLineNum(), path, "missing required attribute 'name'");
    }
    r.record(path + "/@name", el->GetLineNum());
    t.name = name;
    s.getOptional("filter", t.filter, readEnum<ColorFilterMethod>);
    const bool rgb = t.filter == ColorFilterMethod::RgbRatio;
    constexpr std::string_view kRgbWhy = "required when <filter> is rgb_ratio";
    s.getIf(rgb, "redGreen", t.redGreen, readRange, kRgbWhy);
    s.getIf(rgb, "redBlue", t.redBlue, readRange, kRgbWhy);
    s.getIf(rgb, "blueGreen", t.blueGreen, readRange, kRgbWhy);
    if (s.has("brightness")) {
        t.brightness = s.get("brightness", readRange);
    }
    s.getOptional("brightnessBands", t.brightnessBands, readBands);
    if (s.has("veil")) {
        t.veil = s.get("veil", readVeil);
    }
    if (s.has("water")) {
        t.water = s.get("water", readWater);
    }
    s.getIf(!rgb, "hsv", t.hsv, readHsv, "required when <filter> is hsv");
    s.getOptional("erodeRestore", t.erodeRestore, readBool);
    s.getOptional("erodeKernelSize", t.erodeKernelSize, readInt);
    s.getOptional("area", t.area, readRange);
    s.getOptional("aspectRatio", t.aspectRatio, readRange);
    s.getOptional("areaRatio", t.areaRatio, readRange);
    s.getOptional("window", t.window, readWindow);
    s.getOptional("shape", t.shape, readEnum<TargetShape>);
    if (s.has("sizeMm")) {
        t.sizeMm = s.get("sizeMm", readRange);
    }
    return t;
}

/// <targets> holds only <target> elements, addressed as target[1], target[2], ...
TargetConfig readTargets(Reader& r, const XMLElement* el, const std::string& path) {
    return TargetConfig{readList<TargetType>(r, el, path, "target", readTarget)};
}

MatchConfig readMatch(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"method", "box", "epipolarLine", "shape", "repeats"});
    MatchConfig m;
    m.method = s.get("method", readEnum<MatchMethod>);
    s.getOptional("repeats", m.repeats, readEnum<RepeatMatchPolicy>);

    const bool box = m.method == MatchMethod::EpipolarBox;
    if (const XMLElement* b = box ? s.require("box", "required when <method> is epipolar_box") : s.find("box")) {
        const Section bs(r, b, s.childPath("box"), {"dx", "dy"});
        const Range dx = bs.get("dx", readRange);
        const Range dy = bs.get("dy", readRange);
        m.boxDxMin = dx.min;
        m.boxDxMax = dx.max;
        m.boxDyMin = dy.min;
        m.boxDyMax = dy.max;
    }

    const bool line = m.method == MatchMethod::EpipolarLine;
    if (const XMLElement* l = line ? s.require("epipolarLine", "required when <method> is epipolar_line")
                                   : s.find("epipolarLine")) {
        const Section ls(r, l, s.childPath("epipolarLine"), {"maxDistancePx", "rangeMm"});
        m.maxEpipolarDistancePx = ls.get("maxDistancePx", readDouble);
        const Range range = ls.get("rangeMm", readRange);
        m.minRangeMm = range.min;
        m.maxRangeMm = range.max;
    }

    if (const XMLElement* sh = s.find("shape")) {
        const Section ss(r, sh, s.childPath("shape"),
                         {"magnitudeWeight", "directionWeight", "maxError", "maxAreaRatio"});
        ss.getOptional("magnitudeWeight", m.shape.magnitudeWeight, readDouble);
        ss.getOptional("directionWeight", m.shape.directionWeight, readDouble);
        ss.getOptional("maxError", m.shape.maxError, readDouble);
        ss.getOptional("maxAreaRatio", m.shape.maxAreaRatio, readDouble);
    }
    return m;
}

CameraIntrinsics readIntrinsics(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"fc", "cc", "alphaC", "kc"});
    CameraIntrinsics in;
    in.fc = s.get("fc", readVector2);
    in.cc = s.get("cc", readVector2);
    s.getOptional("alphaC", in.alphaC, readDouble);
    s.getOptional("kc", in.kc, readVector5);
    return in;
}

RigidTransform readTransform(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"rotation", "translationMm"});
    return RigidTransform{s.get("rotation", readVector9), s.get("translationMm", readVector3)};
}

IntrinsicsUncertainty readIntrinsicsUncertainty(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"fc", "cc", "alphaC", "kc"});
    IntrinsicsUncertainty u;
    u.fc = s.get("fc", readVector2);
    u.cc = s.get("cc", readVector2);
    s.getOptional("alphaC", u.alphaC, readDouble);
    s.getOptional("kc", u.kc, readVector5);
    return u;
}

CalibrationUncertainty readUncertainty(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"left", "right", "om", "translationMm"});
    CalibrationUncertainty u;
    u.left = s.get("left", readIntrinsicsUncertainty);
    u.right = s.get("right", readIntrinsicsUncertainty);
    u.om = s.get("om", readVector3);
    u.translationMm = s.get("translationMm", readVector3);
    return u;
}

StereoSystemConfig readStereo(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"left", "right", "om", "translationMm", "baseTVision", "uncertainty"});
    StereoSystemConfig st;
    st.left = s.get("left", readIntrinsics);
    st.right = s.get("right", readIntrinsics);
    st.om = s.get("om", readVector3);
    st.translationMm = s.get("translationMm", readVector3);
    if (s.has("baseTVision")) {
        st.baseTVision = s.get("baseTVision", readTransform);
    }
    if (s.has("uncertainty")) {
        st.uncertainty = s.get("uncertainty", readUncertainty);
    }
    return st;
}

FalloffChannel readFalloff(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"coefficient", "exponent"});
    return FalloffChannel{s.get("coefficient", readDouble), s.get("exponent", readDouble)};
}

LightingConfig readLighting(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"frameAverage", "pattern"});
    LightingConfig l;
    if (const XMLElement* fa = s.find("frameAverage")) {
        const Section fs(r, fa, s.childPath("frameAverage"), {"enabled", "gainsRgb"});
        l.frameAverageEnabled = fs.get("enabled", readBool);
        fs.getIf(l.frameAverageEnabled, "gainsRgb", l.gainsRgb, readVector3, "required when <enabled> is true");
    }
    if (const XMLElement* pa = s.find("pattern")) {
        const Section ps(r, pa, s.childPath("pattern"),
                         {"enabled", "centrePx", "red", "green", "blue", "templateImage"});
        l.patternEnabled = ps.get("enabled", readBool);
        ps.getOptional("templateImage", l.templateImagePath, readString);
        const bool analytic = l.patternEnabled && l.templateImagePath.empty();
        constexpr std::string_view kWhy = "required when <enabled> is true and there is no <templateImage>";
        ps.getIf(analytic, "centrePx", l.patternCentrePx, readVector2, kWhy);
        ps.getIf(analytic, "red", l.red, readFalloff, kWhy);
        ps.getIf(analytic, "green", l.green, readFalloff, kWhy);
        ps.getIf(analytic, "blue", l.blue, readFalloff, kWhy);
    }
    return l;
}

VisibilityConfig readVisibility(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"minContrast", "maxSaturatedFraction", "maxHaze"});
    VisibilityConfig v;
    s.getOptional("minContrast", v.minContrast, readDouble);
    s.getOptional("maxSaturatedFraction", v.maxSaturatedFraction, readDouble);
    s.getOptional("maxHaze", v.maxHaze, readDouble);
    return v;
}

TrackingConfig readTracking(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"enabled", "fullFrameEvery", "marginPx"});
    TrackingConfig t;
    t.enabled = s.get("enabled", readBool);
    s.getOptional("fullFrameEvery", t.fullFrameEvery, readInt);
    s.getOptional("marginPx", t.marginPx, readInt);
    return t;
}

CoarseToFineConfig readCoarseToFine(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path, {"enabled", "marginPx"});
    CoarseToFineConfig c;
    c.enabled = s.get("enabled", readBool);
    s.getOptional("marginPx", c.marginPx, readInt);
    return c;
}

AnalysisConfig readAnalysis(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path,
                    {"stages", "demosaic", "centroid", "triangulation", "visibility", "tracking", "coarseToFine", "threads"});
    AnalysisConfig a;
    s.getOptional("stages", a.stages, readWords);
    s.getOptional("demosaic", a.demosaic, readEnum<DemosaicAlgorithm>);
    s.getOptional("centroid", a.centroid, readEnum<CentroidMode>);
    s.getOptional("triangulation", a.triangulation, readEnum<TriangulationMode>);
    s.getOptional("visibility", a.visibility, readVisibility);
    s.getOptional("tracking", a.tracking, readTracking);
    s.getOptional("coarseToFine", a.coarseToFine, readCoarseToFine);
    s.getOptional("threads", a.threads, readInt);
    return a;
}

ServoConfig readServo(Reader& r, const XMLElement* el, const std::string& path) {
    const Section s(r, el, path,
                    {"sampleType", "armType", "mode", "filter", "maxMoveMm", "finalDistanceMm", "toolOffsetMm",
                     "armToleranceMm", "armDriftMm", "armDriftPerMm", "maxTargetJumpMm", "trackingRadiusMm",
                     "visionTimeoutMs", "moveTimeoutMs", "lostTimeoutMs", "maxIterations", "refineRegistration",
                     "probeAngleDeg", "registrationStdDeg", "kalman"});
    ServoConfig c;
    s.getOptional("sampleType", c.sampleType, readString);
    s.getOptional("armType", c.armType, readString);
    s.getOptional("mode", c.mode, readEnum<ServoMode>);
    s.getOptional("filter", c.filter, readEnum<ServoFilter>);
    s.getOptional("maxMoveMm", c.maxMoveMm, readDouble);
    s.getOptional("finalDistanceMm", c.finalDistanceMm, readDouble);
    s.getOptional("toolOffsetMm", c.toolOffsetMm, readVector3);
    s.getOptional("armToleranceMm", c.armToleranceMm, readDouble);
    s.getOptional("armDriftMm", c.armDriftMm, readDouble);
    s.getOptional("armDriftPerMm", c.armDriftPerMm, readDouble);
    s.getOptional("maxTargetJumpMm", c.maxTargetJumpMm, readDouble);
    s.getOptional("trackingRadiusMm", c.trackingRadiusMm, readDouble);
    s.getOptional("visionTimeoutMs", c.visionTimeoutMs, readInt);
    s.getOptional("moveTimeoutMs", c.moveTimeoutMs, readInt);
    s.getOptional("lostTimeoutMs", c.lostTimeoutMs, readInt);
    s.getOptional("maxIterations", c.maxIterations, readInt);
    s.getOptional("refineRegistration", c.refineRegistration, readBool);
    s.getOptional("probeAngleDeg", c.probeAngleDeg, readDouble);
    s.getOptional("registrationStdDeg", c.registrationStdDeg, readDouble);
    if (const XMLElement* k = s.find("kalman")) {
        const Section ks(r, k, s.childPath("kalman"), {"sampleNoiseMm", "armNoisePerMm", "defaultSigmaMm"});
        ks.getOptional("sampleNoiseMm", c.kalmanSampleNoiseMm, readDouble);
        ks.getOptional("armNoisePerMm", c.kalmanArmNoisePerMm, readDouble);
        ks.getOptional("defaultSigmaMm", c.kalmanDefaultSigmaMm, readDouble);
    }
    return c;
}

/// What tinyxml2 lets through but a configuration must not hold: a NUL byte
/// (tinyxml2 stops reading there, so whatever follows would be ignored) and
/// entity references other than XML's five and character references
/// (tinyxml2 keeps an undeclared one as literal text). Comments and CDATA
/// sections are not looked into.
void checkRawText(const std::string& xml, const Reader& r) {
    const auto lineAt = [&](std::size_t offset) {
        return 1 + static_cast<int>(std::count(xml.begin(), xml.begin() + static_cast<std::ptrdiff_t>(offset), '\n'));
    };
    if (const std::size_t nul = xml.find('\0'); nul != std::string::npos) {
        r.fail(lineAt(nul), "/", "malformed XML: a NUL byte at offset " + std::to_string(nul) +
                                     " (nothing may follow the document, and no NUL may be in it)");
    }
    std::size_t i = 0;
    while ((i = xml.find_first_of("<&", i)) != std::string::npos) {
        if (xml.compare(i, 4, "<!--") == 0) {
            const std::size_t end = xml.find("-->", i + 4);
            i = end == std::string::npos ? xml.size() : end + 3;
            continue;
        }
        if (xml.compare(i, 9, "<![CDATA[") == 0) {
            const std::size_t end = xml.find("]]>", i + 9);
            i = end == std::string::npos ? xml.size() : end + 3;
            continue;
        }
        if (xml[i] == '<') {
            ++i;
            continue;
        }
        const std::size_t semicolon = xml.find(';', i + 1);
        const std::string name =
            semicolon == std::string::npos || semicolon - i > 32 ? std::string() : xml.substr(i + 1, semicolon - i - 1);
        const bool known = name == "amp" || name == "lt" || name == "gt" || name == "quot" || name == "apos" ||
                           (name.size() > 1 && name[0] == '#');
        if (!known) {
            r.fail(lineAt(i), "/",
                   name.empty() || name.find_first_of(" \t\r\n<&") != std::string::npos
                       ? std::string("malformed XML: a '&' that starts no entity reference (write &amp;)")
                       : "undeclared entity '&" + name + ";' (only &amp; &lt; &gt; &quot; &apos; and character "
                                                          "references are allowed)");
        }
        i = semicolon + 1;
    }
}

}  // namespace

TargetType parseTarget(const std::string& xml, const std::string& source, LineMap& lines) {
    Reader r(source, lines);
    checkRawText(xml, r);
    XMLDocument doc;
    if (doc.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS) {
        r.fail(doc.ErrorLineNum(), "/", malformedMessage(doc));
    }
    const XMLElement* root = doc.RootElement();
    if (root == nullptr) {
        r.fail(0, "/", "malformed XML: the document has no element");
    }
    if (std::string_view(root->Name()) != "target") {
        r.fail(root->GetLineNum(), std::string("/") + root->Name(),
               "expected a <target> element, got " + element(root->Name()));
    }
    if (const XMLElement* second = root->NextSiblingElement()) {
        r.fail(second->GetLineNum(), std::string("/") + second->Name(),
               "unexpected second element " + element(second->Name()));
    }
    return readTarget(r, root, "/target");
}

ParsedDocument parseDocument(const std::string& xml, const std::string& source) {
    ParsedDocument parsed;
    Reader r(source, parsed.lines);

    checkRawText(xml, r);
    XMLDocument doc;  // entities processed, white space preserved (trimmed per value)
    if (doc.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS) {
        r.fail(doc.ErrorLineNum(), "/", malformedMessage(doc));
    }
    const XMLElement* root = doc.RootElement();
    if (root == nullptr) {
        r.fail(0, "/", "malformed XML: the document has no element");
    }
    if (std::string_view(root->Name()) != "avatar") {
        r.fail(root->GetLineNum(), std::string("/") + root->Name(),
               "expected root element <avatar>, got " + element(root->Name()));
    }
    if (const XMLElement* second = root->NextSiblingElement()) {
        r.fail(second->GetLineNum(), std::string("/") + second->Name(),
               "unexpected second root element " + element(second->Name()));
    }
    // The version comes first: a newer document may use elements this build does not know.
    const char* version = root->Attribute("version");
    if (version == nullptr) {
        r.fail(root->GetLineNum(), "/avatar", "missing required attribute 'version'");
    }
    if (std::string_view(version) != "1") {
        r.fail(root->GetLineNum(), "/avatar/@version",
               "unsupported version " + quote(version) + " (this build reads version 1)");
    }
    r.record("/avatar/@version", root->GetLineNum());

    const Section s(r, root, "/avatar", {"camera", "targets", "match", "stereo", "lighting", "analysis", "servo"},
                    {"version"});
    AvatarConfig& c = parsed.config;
    c.camera = s.get("camera", readCamera);
    c.targets = s.get("targets", readTargets);
    c.match = s.get("match", readMatch);
    c.stereo = s.get("stereo", readStereo);
    s.getOptional("lighting", c.lighting, readLighting);
    s.getOptional("analysis", c.analysis, readAnalysis);
    if (s.has("servo")) {
        c.servo = s.get("servo", readServo);
    }
    return parsed;
}

}  // namespace avatar::config_internal
