// Rejected documents and configurations: every error class with its exact message.

#include "TestConfigs.h"

#include <avatar/config/ConfigXml.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace avatar {
namespace {

// A valid document with one element per line, so that the line numbers in the
// expected messages below can be checked by eye (the numbers on the right).
const std::string kBase = R"(<?xml version="1.0"?>
<avatar version="1">
  <camera>
    <width>1280</width>
    <height>960</height>
    <bitDepth>16</bitDepth>
    <channels>1</channels>
    <bayer>true</bayer>
    <bayerPattern>BG</bayerPattern>
    <features>
      <gain><value>5</value><auto>false</auto></gain>
    </features>
  </camera>
  <targets>
    <target name="sample">
      <redGreen><min>0.9</min><max>1.6</max></redGreen>
      <redBlue><min>2.5</min><max>100</max></redBlue>
      <blueGreen><min>0</min><max>0.45</max></blueGreen>
      <erodeKernelSize>3</erodeKernelSize>
      <area><min>150</min><max>1e9</max></area>
      <areaRatio><min>0.3</min><max>1</max></areaRatio>
    </target>
    <target name="marker">
      <redGreen><min>1.3</min><max>2.2</max></redGreen>
      <redBlue><min>1.8</min><max>6</max></redBlue>
      <blueGreen><min>0</min><max>0.6</max></blueGreen>
      <window><x>0</x><y>0</y><width>640</width><height>480</height></window>
    </target>
  </targets>
  <match>
    <method>epipolar_box</method>
    <box><dx><min>37</min><max>280</max></dx><dy><min>-8</min><max>8</max></dy></box>
  </match>
  <stereo>
    <left><fc>1049.13 1050.38</fc><cc>712.28 564.45</cc></left>
    <right><fc>1047.2 1048.66</fc><cc>702.74 561.13</cc></right>
    <om>0.002 0.003 0.047</om>
    <translationMm>-106.53 -2.58 0.82</translationMm>
    <baseTVision>
      <rotation>0 -1 0 1 0 0 0 0 1</rotation>
      <translationMm>100 200 300</translationMm>
    </baseTVision>
  </stereo>
  <lighting>
    <pattern>
      <enabled>true</enabled>
      <centrePx>640 480</centrePx>
      <red><coefficient>1</coefficient><exponent>0.0015</exponent></red>
      <green><coefficient>1</coefficient><exponent>0.001</exponent></green>
      <blue><coefficient>1</coefficient><exponent>0.0008</exponent></blue>
    </pattern>
  </lighting>
</avatar>
)";
// Lines: 2 avatar, 3 camera, 4 width, 5 height, 6 bitDepth, 7 channels, 8 bayer,
// 9 bayerPattern, 10 features, 11 gain, 14 targets, 15 target[1], 16 redGreen,
// 17 redBlue, 18 blueGreen, 19 erodeKernelSize, 20 area, 21 areaRatio,
// 23 target[2], 24 redGreen, 25 redBlue, 26 blueGreen, 27 window, 30 match,
// 31 method, 32 box, 34 stereo, 35 left, 36 right, 37 om, 38 translationMm,
// 39 baseTVision, 40 rotation, 41 translationMm, 44 lighting, 45 pattern,
// 46 enabled, 47 centrePx, 48 red, 49 green, 50 blue, 53 </avatar>.

struct BadDocument {
    const char* what;  ///< the error class, for the test's output
    std::vector<std::pair<std::string, std::string>> edits;  ///< each replaces the first occurrence
    std::string expected;                                    ///< ConfigError::what()
};

std::ostream& operator<<(std::ostream& os, const BadDocument& d) {
    return os << d.what;
}

std::string edit(std::string doc, const std::vector<std::pair<std::string, std::string>>& edits) {
    for (const auto& [from, to] : edits) {
        const std::size_t at = doc.find(from);
        if (at == std::string::npos) {
            ADD_FAILURE() << "edit target not in the base document: " << from;
            return doc;
        }
        doc.replace(at, from.size(), to);
    }
    return doc;
}

TEST(ConfigErrors, BaseDocumentIsValid) {
    const AvatarConfig c = readConfigString(kBase, "t.xml");
    EXPECT_EQ(c.camera.width, 1280);
    ASSERT_EQ(c.targets.targets.size(), 2u);
    EXPECT_EQ(c.targets.targets[1].name, "marker");
    EXPECT_EQ(c.targets.targets[1].window.height, 480);
    EXPECT_EQ(c.camera.features.gain.value, 5.0);
    EXPECT_TRUE(c.lighting.patternEnabled);
}

const std::vector<BadDocument> kBadDocuments = {
    // Malformed XML, reported with tinyxml2's line.
    {"mismatched end tag", {{"    </features>\n", ""}},
     "t.xml:10: /: malformed XML: mismatched end tag in element <features> (XML_ERROR_MISMATCHED_ELEMENT)"},
    {"unquoted attribute", {{"<target name=\"marker\">", "<target name=marker>"}},
     "t.xml:23: /: malformed XML: cannot parse an attribute in element <target> (XML_ERROR_PARSING_ATTRIBUTE)"},
    {"duplicate attribute", {{"<target name=\"marker\">", "<target name=\"a\" name=\"b\">"}},
     "t.xml:23: /: malformed XML: cannot parse an attribute in element <target> (XML_ERROR_PARSING_ATTRIBUTE)"},
    {"text after the root", {{"</avatar>\n", "</avatar>\ntrailing\n"}},
     "t.xml:54: /: malformed XML: cannot parse text (XML_ERROR_PARSING_TEXT)"},
    {"empty document", {{kBase, ""}},
     "t.xml:0: /: malformed XML: the document has no element (XML_ERROR_EMPTY_DOCUMENT)"},

    // Document structure.
    {"wrong root", {{"<avatar version=\"1\">", "<config version=\"1\">"}, {"</avatar>", "</config>"}},
     "t.xml:2: /config: expected root element <avatar>, got <config>"},
    {"second root", {{"</avatar>\n", "</avatar>\n<extra/>\n"}},
     "t.xml:54: /extra: unexpected second root element <extra>"},
    {"missing version", {{"<avatar version=\"1\">", "<avatar>"}},
     "t.xml:2: /avatar: missing required attribute 'version'"},
    {"unsupported version", {{"<avatar version=\"1\">", "<avatar version=\"2\">"}},
     "t.xml:2: /avatar/@version: unsupported version '2' (this build reads version 1)"},
    {"unknown attribute on the root", {{"<avatar version=\"1\">", "<avatar version=\"1\" mode=\"x\">"}},
     "t.xml:2: /avatar/@mode: unknown attribute 'mode'"},
    {"unknown attribute on a value", {{"<width>", "<width unit=\"px\">"}},
     "t.xml:4: /avatar/camera/width/@unit: unknown attribute 'unit'"},
    {"unknown element", {{"<bitDepth>16</bitDepth>", "<bitDepth>16</bitDepth><colour>red</colour>"}},
     "t.xml:6: /avatar/camera/colour: unknown element <colour>"},
    {"unknown top-level section", {{"  <match>\n", "  <extras/>\n  <match>\n"}},
     "t.xml:30: /avatar/extras: unknown element <extras>"},
    {"unknown element in targets", {{"<target name=\"marker\">", "<tgt/><target name=\"marker\">"}},
     "t.xml:23: /avatar/targets/tgt: unknown element <tgt>"},
    {"element inside a value", {{"<width>1280</width>", "<width>1280<px/></width>"}},
     "t.xml:4: /avatar/camera/width/px: unknown element <px>"},
    {"text inside a section", {{"<camera>", "<camera>oops"}},
     "t.xml:3: /avatar/camera: unexpected text 'oops'"},
    {"duplicate element", {{"<height>960</height>\n", "<height>960</height>\n    <height>961</height>\n"}},
     "t.xml:6: /avatar/camera/height: duplicate element <height> (first at line 5)"},
    {"duplicate section", {{"  </lighting>\n", "  </lighting>\n  <lighting/>\n"}},
     "t.xml:53: /avatar/lighting: duplicate element <lighting> (first at line 44)"},
    {"missing required element", {{"    <bitDepth>16</bitDepth>\n", ""}},
     "t.xml:3: /avatar/camera: missing required element <bitDepth>"},
    {"missing required element in a range", {{"<max>0.6</max>", ""}},
     "t.xml:26: /avatar/targets/target[2]/blueGreen: missing required element <max>"},
    {"missing required section",
     {{"  <match>\n    <method>epipolar_box</method>\n    <box><dx><min>37</min><max>280</max></dx>"
       "<dy><min>-8</min><max>8</max></dy></box>\n  </match>\n",
       ""}},
     "t.xml:2: /avatar: missing required element <match>"},
    {"missing conditional element", {{"    <bayerPattern>BG</bayerPattern>\n", ""}},
     "t.xml:3: /avatar/camera: missing element <bayerPattern> (required when <bayer> is true)"},
    {"missing rgb ranges", {{"      <redBlue><min>1.8</min><max>6</max></redBlue>\n", ""}},
     "t.xml:23: /avatar/targets/target[2]: missing element <redBlue> (required when <filter> is rgb_ratio)"},
    {"missing epipolar line parameters", {{"epipolar_box", "epipolar_line"}},
     "t.xml:30: /avatar/match: missing element <epipolarLine> (required when <method> is epipolar_line)"},
    {"missing falloff channel",
     {{"      <red><coefficient>1</coefficient><exponent>0.0015</exponent></red>\n", ""}},
     "t.xml:45: /avatar/lighting/pattern: missing element <red> (required when <enabled> is true and there is no "
     "<templateImage>)"},
    {"missing target name", {{"<target name=\"marker\">", "<target>"}},
     "t.xml:23: /avatar/targets/target[2]: missing required attribute 'name'"},

    // Value syntax.
    {"not an integer", {{"<width>1280</width>", "<width>12.5</width>"}},
     "t.xml:4: /avatar/camera/width: expected an integer, got '12.5'"},
    {"integer out of range", {{"<height>960</height>", "<height>99999999999</height>"}},
     "t.xml:5: /avatar/camera/height: integer out of range, got '99999999999'"},
    {"not a number", {{"<min>1.3</min>", "<min>abc</min>"}},
     "t.xml:24: /avatar/targets/target[2]/redGreen/min: expected a number, got 'abc'"},
    {"empty number", {{"<exponent>0.001</exponent>", "<exponent></exponent>"}},
     "t.xml:49: /avatar/lighting/pattern/green/exponent: expected a number, got ''"},
    {"not finite", {{"<exponent>0.0015</exponent>", "<exponent>nan</exponent>"}},
     "t.xml:48: /avatar/lighting/pattern/red/exponent: expected a finite number, got 'nan'"},
    {"number out of range", {{"<translationMm>100 200 300</translationMm>", "<translationMm>100 1e999 300</translationMm>"}},
     "t.xml:41: /avatar/stereo/baseTVision/translationMm: number out of range, got '1e999'"},
    {"not a boolean", {{"<bayer>true</bayer>", "<bayer>yes</bayer>"}},
     "t.xml:8: /avatar/camera/bayer: expected true or false, got 'yes'"},
    {"unknown method", {{"epipolar_box", "box"}},
     "t.xml:31: /avatar/match/method: expected shape, epipolar_box or epipolar_line, got 'box'"},
    {"unknown repeat policy", {{"<method>epipolar_box</method>", "<method>epipolar_box</method><repeats>drop</repeats>"}},
     "t.xml:31: /avatar/match/repeats: expected void or reassign, got 'drop'"},
    {"unknown Bayer pattern", {{">BG<", ">bg<"}},
     "t.xml:9: /avatar/camera/bayerPattern: expected BG, GB, RG or GR, got 'bg'"},
    {"unknown filter", {{"<redGreen><min>0.9", "<filter>lab</filter><redGreen><min>0.9"}},
     "t.xml:16: /avatar/targets/target[1]/filter: expected rgb_ratio or hsv, got 'lab'"},
    {"too few numbers", {{"<fc>1049.13 1050.38</fc>", "<fc>1049.13</fc>"}},
     "t.xml:35: /avatar/stereo/left/fc: expected 2 numbers, got 1"},
    {"too many numbers", {{"<om>0.002 0.003 0.047</om>", "<om>0.002 0.003 0.047 0</om>"}},
     "t.xml:37: /avatar/stereo/om: expected 3 numbers, got 4"},
    {"bad vector component", {{"<om>0.002 0.003 0.047</om>", "<om>0.002 x 0.047</om>"}},
     "t.xml:37: /avatar/stereo/om: expected a number, got 'x'"},

    // Value rules.
    {"width zero", {{"<width>1280</width>", "<width>0</width>"}},
     "t.xml:4: /avatar/camera/width: must be between 1 and 16384, got 0"},
    {"bit depth 17", {{"<bitDepth>16</bitDepth>", "<bitDepth>17</bitDepth>"}},
     "t.xml:6: /avatar/camera/bitDepth: must be between 1 and 16, got 17"},
    {"Bayer with three channels", {{"<channels>1</channels>", "<channels>3</channels>"}},
     "t.xml:7: /avatar/camera/channels: must be 1 when <bayer> is true, got 3"},
    {"even kernel", {{"<erodeKernelSize>3</erodeKernelSize>", "<erodeKernelSize>4</erodeKernelSize>"}},
     "t.xml:19: /avatar/targets/target[1]/erodeKernelSize: must be odd, got 4"},
    {"area ratio above 1", {{"<min>0.3</min><max>1</max>", "<min>0.3</min><max>1.5</max>"}},
     "t.xml:21: /avatar/targets/target[1]/areaRatio/max: must be between 0 and 1, got 1.5"},
    {"negative ratio", {{"<min>1.8</min>", "<min>-1.8</min>"}},
     "t.xml:25: /avatar/targets/target[2]/redBlue/min: must be >= 0, got -1.8"},
    {"min above max", {{"<min>2.5</min><max>100</max>", "<min>200</min><max>100</max>"}},
     "t.xml:17: /avatar/targets/target[1]/redBlue: min 200 is above max 100"},
    {"focal length zero", {{"<fc>1047.2 1048.66</fc>", "<fc>1047.2 0</fc>"}},
     "t.xml:36: /avatar/stereo/right/fc: component 2 must be between 1 and 1e+06, got 0"},
    {"principal point outside the image", {{"<cc>712.28 564.45</cc>", "<cc>1500 564.45</cc>"}},
     "t.xml:35: /avatar/stereo/left/cc: component 1 (x, image width 1280) must be between 0 and 1280, got 1500"},
    {"zero baseline", {{"<translationMm>-106.53 -2.58 0.82</translationMm>", "<translationMm>0 0 0</translationMm>"}},
     "t.xml:38: /avatar/stereo/translationMm: the baseline must not be zero"},
    {"not a rotation", {{"0 -1 0 1 0 0 0 0 1", "0 -1 0 1 0 0 0 0 2"}},
     "t.xml:40: /avatar/stereo/baseTVision/rotation: is not a rotation matrix: largest element of |R R^T - I| is 3, "
     "more than 0.001"},
    {"reflection", {{"0 -1 0 1 0 0 0 0 1", "0 1 0 1 0 0 0 0 1"}},
     "t.xml:40: /avatar/stereo/baseTVision/rotation: is not a rotation matrix: determinant -1 (a reflection)"},
    {"window outside the image", {{"<width>640</width>", "<width>1281</width>"}},
     "t.xml:27: /avatar/targets/target[2]/window/width: x + width = 1281 exceeds the image width 1280"},
    {"half-empty window", {{"<height>480</height>", "<height>0</height>"}},
     "t.xml:27: /avatar/targets/target[2]/window: width and height must both be 0 (whole image) or both be > 0, "
     "got 640 x 0"},
    {"duplicate target name", {{"<target name=\"marker\">", "<target name=\"sample\">"}},
     "t.xml:23: /avatar/targets/target[2]/@name: duplicate target name 'sample' (also target[1])"},
    {"bad target name", {{"<target name=\"marker\">", "<target name=\"my duck\">"}},
     "t.xml:23: /avatar/targets/target[2]/@name: must be a non-empty name of letters, digits, '_' and '-', got "
     "'my duck'"},
    {"no target", {{"<targets>", "<targets/><!--"}, {"</targets>", "-->"}},
     "t.xml:14: /avatar/targets: at least one <target> is required"},
    {"box min above max", {{"<dy><min>-8</min><max>8</max></dy>", "<dy><min>8</min><max>-8</max></dy>"}},
     "t.xml:32: /avatar/match/box/dy: min 8 is above max -8"},
    {"unknown target shape", {{"<erodeKernelSize>3</erodeKernelSize>", "<erodeKernelSize>3</erodeKernelSize><shape>cube</shape>"}},
     "t.xml:19: /avatar/targets/target[1]/shape: expected none, sphere, disc or composite, got 'cube'"},
    {"unknown demosaic algorithm", {{"  </lighting>\n", "  </lighting>\n  <analysis><demosaic>ahd</demosaic></analysis>\n"}},
     "t.xml:53: /avatar/analysis/demosaic: expected bilinear or edge_aware, got 'ahd'"},
    {"removed nine-point triangulation",
     {{"  </lighting>\n", "  </lighting>\n  <analysis><triangulation>nine_points</triangulation></analysis>\n"}},
     "t.xml:53: /avatar/analysis/triangulation: expected centroid (nine_points was removed: docs/accuracy.md), "
     "got 'nine_points'"},
    {"stage twice", {{"  </lighting>\n", "  </lighting>\n  <analysis><stages>demosaic match demosaic</stages></analysis>\n"}},
     "t.xml:53: /avatar/analysis/stages: stage 'demosaic' appears twice"},
    {"bad stage name", {{"  </lighting>\n", "  </lighting>\n  <analysis><stages>Demosaic</stages></analysis>\n"}},
     "t.xml:53: /avatar/analysis/stages: stage 'Demosaic' is not a name of lower-case letters, digits and '_'"},
    {"no stages", {{"  </lighting>\n", "  </lighting>\n  <analysis><stages/></analysis>\n"}},
     "t.xml:53: /avatar/analysis/stages: at least one stage is required"},
    {"haze above 1", {{"  </lighting>\n", "  </lighting>\n  <analysis><visibility><maxHaze>1.5</maxHaze></visibility></analysis>\n"}},
     "t.xml:53: /avatar/analysis/visibility/maxHaze: must be between 0 and 1, got 1.5"},
    {"tracking margin too small",
     {{"  </lighting>\n", "  </lighting>\n  <analysis><tracking><enabled>true</enabled><marginPx>4</marginPx></tracking></analysis>\n"}},
     "t.xml:53: /avatar/analysis/tracking/marginPx: must be between 8 and 100000, got 4"},
    {"coarse margin too small",
     {{"  </lighting>\n", "  </lighting>\n  <analysis><coarseToFine><enabled>true</enabled><marginPx>0</marginPx></coarseToFine></analysis>\n"}},
     "t.xml:53: /avatar/analysis/coarseToFine/marginPx: must be between 8 and 100000, got 0"},
    {"three threads", {{"  </lighting>\n", "  </lighting>\n  <analysis><threads>3</threads></analysis>\n"}},
     "t.xml:53: /avatar/analysis/threads: must be between 1 and 2, got 3"},
    {"tracking without enabled",
     {{"  </lighting>\n", "  </lighting>\n  <analysis><tracking><marginPx>40</marginPx></tracking></analysis>\n"}},
     "t.xml:53: /avatar/analysis/tracking: missing required element <enabled>"},
    {"servo type not a target", {{"  </lighting>\n", "  </lighting>\n  <servo><armType>gripper</armType></servo>\n"}},
     "t.xml:53: /avatar/servo/armType: names no target type of <targets>: 'gripper' (types: 'sample', 'marker')"},
    {"servo default arm type missing", {{"  </lighting>\n", "  </lighting>\n  <servo/>\n"}},
     "t.xml:53: /avatar/servo/armType: names no target type of <targets>: 'arm_marker' (types: 'sample', 'marker')"},
    {"servo arm is the sample", {{"  </lighting>\n", "  </lighting>\n  <servo><armType>sample</armType></servo>\n"}},
     "t.xml:53: /avatar/servo/armType: is the same type as <sampleType> 'sample': the arm and the sample must be told apart"},
    {"servo final move longer than d_max", {{"  </lighting>\n", "  </lighting>\n  <servo><armType>marker</armType><finalDistanceMm>80</finalDistanceMm></servo>\n"}},
     "t.xml:53: /avatar/servo/finalDistanceMm: must not exceed <maxMoveMm> 50, got 80: the last move would be longer than any other"},
    {"servo unknown mode", {{"  </lighting>\n", "  </lighting>\n  <servo><armType>marker</armType><mode>visual</mode></servo>\n"}},
     "t.xml:53: /avatar/servo/mode: expected servo, dead_reckoning or hybrid, got 'visual'"},
    {"servo zero timeout", {{"  </lighting>\n", "  </lighting>\n  <servo><armType>marker</armType><visionTimeoutMs>0</visionTimeoutMs></servo>\n"}},
     "t.xml:53: /avatar/servo/visionTimeoutMs: must be between 1 and 600000, got 0"},
    {"servo negative move", {{"  </lighting>\n", "  </lighting>\n  <servo><armType>marker</armType><maxMoveMm>-5</maxMoveMm></servo>\n"}},
     "t.xml:53: /avatar/servo/maxMoveMm: must be > 0, got -5"},
    {"servo unknown element", {{"  </lighting>\n", "  </lighting>\n  <servo><armType>marker</armType><gain>2</gain></servo>\n"}},
     "t.xml:53: /avatar/servo/gain: unknown element <gain>"},
    {"huge baseline", {{"<translationMm>-106.53 -2.58 0.82</translationMm>\n    <baseTVision>", "<translationMm>1e308 1e308 1e308</translationMm>\n    <baseTVision>"}},
     "t.xml:38: /avatar/stereo/translationMm: the baseline |T| (mm) must be between 1 and 1e+05, got 1.7320508075688772e+308"},
    {"denormal baseline", {{"<translationMm>-106.53 -2.58 0.82</translationMm>\n    <baseTVision>", "<translationMm>1e-320 0 0</translationMm>\n    <baseTVision>"}},
     "t.xml:38: /avatar/stereo/translationMm: the baseline |T| (mm) must be between 1 and 1e+05, got 1e-320"},
    {"huge focal length", {{"<fc>1049.13 1050.38</fc>", "<fc>1e300 1050.38</fc>"}},
     "t.xml:35: /avatar/stereo/left/fc: component 1 must be between 1 and 1e+06, got 1e+300"},
    {"tiny focal length", {{"<fc>1049.13 1050.38</fc>", "<fc>1e-300 1050.38</fc>"}},
     "t.xml:35: /avatar/stereo/left/fc: component 1 must be between 1 and 1e+06, got 1e-300"},
    {"huge distortion", {{"<left><fc>1049.13 1050.38</fc><cc>712.28 564.45</cc></left>", "<left><fc>1049.13 1050.38</fc><cc>712.28 564.45</cc><kc>1e300 0 0 0 0</kc></left>"}},
     "t.xml:35: /avatar/stereo/left/kc: component 1 must be between -1000 and 1000, got 1e+300"},
    {"huge rotation vector", {{"<om>0.002 0.003 0.047</om>", "<om>1e200 0 0</om>"}},
     "t.xml:37: /avatar/stereo/om: the rotation angle |om| must be at most pi (180 degrees), got 1e+200 rad"},
    {"huge registration translation", {{"<translationMm>100 200 300</translationMm>", "<translationMm>1e308 200 300</translationMm>"}},
     "t.xml:41: /avatar/stereo/baseTVision/translationMm: component 1 must be between -1e+07 and 1e+07, got 1e+308"},
    {"undeclared entity", {{"<method>epipolar_box</method>", "<method>&shape;</method>"}},
     "t.xml:31: /: undeclared entity '&shape;' (only &amp; &lt; &gt; &quot; &apos; and character references are allowed)"},
    {"bare ampersand", {{"<method>epipolar_box</method>", "<method>epipolar & box</method>"}},
     "t.xml:31: /: malformed XML: a '&' that starts no entity reference (write &amp;)"},
    {"text after the root element", {{"</avatar>\n", "</avatar>\njunk\n"}},
     "t.xml:54: /: malformed XML: cannot parse text (XML_ERROR_PARSING_TEXT)"},
    {"falloff coefficient zero", {{"<coefficient>1</coefficient><exponent>0.0008", "<coefficient>0</coefficient><exponent>0.0008"}},
     "t.xml:50: /avatar/lighting/pattern/blue/coefficient: must be > 0, got 0"},

    // Brightness bands (thesis 3.3.2).
    {"overlapping brightness bands", {{"<blueGreen><min>0</min><max>0.6</max></blueGreen>", "<blueGreen><min>0</min><max>0.6</max></blueGreen><brightnessBands><band><brightness><min>0</min><max>90</max></brightness><redGreen><min>1</min><max>2</max></redGreen><redBlue><min>1</min><max>2</max></redBlue><blueGreen><min>0</min><max>1</max></blueGreen></band><band><brightness><min>80</min><max>200</max></brightness><redGreen><min>1</min><max>2</max></redGreen><redBlue><min>1</min><max>2</max></redBlue><blueGreen><min>0</min><max>1</max></blueGreen></band></brightnessBands>"}},
     "t.xml:26: /avatar/targets/target[2]/brightnessBands/band[2]/brightness: overlaps band[1] (0..90)"},
    {"size range reversed", {{"<blueGreen><min>0</min><max>0.6</max></blueGreen>", "<blueGreen><min>0</min><max>0.6</max></blueGreen><sizeMm><min>90</min><max>60</max></sizeMm>"}},
     "t.xml:26: /avatar/targets/target[2]/sizeMm: min 90 is above max 60"},
    {"brightness band without a ratio", {{"<blueGreen><min>0</min><max>0.6</max></blueGreen>", "<blueGreen><min>0</min><max>0.6</max></blueGreen><brightnessBands><band><brightness><min>0</min><max>90</max></brightness></band></brightnessBands>"}},
     "t.xml:26: /avatar/targets/target[2]/brightnessBands/band[1]: missing required element <redGreen>"},
    {"brightness bands hold bands only", {{"<blueGreen><min>0</min><max>0.6</max></blueGreen>", "<blueGreen><min>0</min><max>0.6</max></blueGreen><brightnessBands><range/></brightnessBands>"}},
     "t.xml:26: /avatar/targets/target[2]/brightnessBands/range: unknown element <range>"},

    // The haze's veil.
    {"veil of two colours", {{"<blueGreen><min>0</min><max>0.6</max></blueGreen>", "<blueGreen><min>0</min><max>0.6</max></blueGreen><veil><colourRgb>0.7 1</colourRgb><maxShare>0.3</maxShare></veil>"}},
     "t.xml:26: /avatar/targets/target[2]/veil/colourRgb: expected 3 numbers, got 2"},
    {"veil without a share", {{"<blueGreen><min>0</min><max>0.6</max></blueGreen>", "<blueGreen><min>0</min><max>0.6</max></blueGreen><veil><colourRgb>0.7 1 1</colourRgb></veil>"}},
     "t.xml:26: /avatar/targets/target[2]/veil: missing required element <maxShare>"},
    {"veil's share of all", {{"<blueGreen><min>0</min><max>0.6</max></blueGreen>", "<blueGreen><min>0</min><max>0.6</max></blueGreen><veil><colourRgb>0.7 1 1</colourRgb><maxShare>1</maxShare></veil>"}},
     "t.xml:26: /avatar/targets/target[2]/veil/maxShare: must be above 0 and below 1 (at 1 the veil alone passes), got 1"},
    // The site's water.
    {"water without a path", {{"<blueGreen><min>0</min><max>0.6</max></blueGreen>", "<blueGreen><min>0</min><max>0.6</max></blueGreen><water><attenuationPerM>0.2 0.03 0.08</attenuationPerM></water>"}},
     "t.xml:26: /avatar/targets/target[2]/water: missing required element <maxPathM>"},
    {"water of two channels", {{"<blueGreen><min>0</min><max>0.6</max></blueGreen>", "<blueGreen><min>0</min><max>0.6</max></blueGreen><water><attenuationPerM>0.2 0.03</attenuationPerM><maxPathM>5</maxPathM></water>"}},
     "t.xml:26: /avatar/targets/target[2]/water/attenuationPerM: expected 3 numbers, got 2"},
};

class BadDocumentTest : public ::testing::TestWithParam<BadDocument> {};

TEST_P(BadDocumentTest, IsRejectedWithItsMessage) {
    const BadDocument& bad = GetParam();
    const std::string doc = edit(kBase, bad.edits);
    ASSERT_NE(doc, kBase);
    try {
        readConfigString(doc, "t.xml");
        ADD_FAILURE() << "accepted:\n" << doc;
    } catch (const ConfigError& e) {
        EXPECT_EQ(std::string(e.what()), bad.expected);
        // The parts agree with the message.
        EXPECT_EQ(e.source(), "t.xml");
        EXPECT_EQ(std::string(e.what()), e.source() + ":" + std::to_string(e.line()) + ": " + e.elementPath() +
                                             ": " + e.problem());
    }
}

INSTANTIATE_TEST_SUITE_P(Table, BadDocumentTest, ::testing::ValuesIn(kBadDocuments));

TEST(ConfigErrors, TableIsLargeEnough) {
    EXPECT_GE(kBadDocuments.size(), 25u);
}

// tinyxml2 stops at a NUL: a valid document followed by one and anything else
// must not be taken for the document alone.
TEST(ConfigErrors, ANulByteAndWhatFollowsIsRejected) {
    std::string doc = kBase;
    doc += std::string(1, '\0') + "<avatar version=\"1\">junk";
    try {
        readConfigString(doc, "t.xml");
        ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
        EXPECT_EQ(std::string(e.what()), "t.xml:54: /: malformed XML: a NUL byte at offset " +
                                             std::to_string(kBase.size()) +
                                             " (nothing may follow the document, and no NUL may be in it)");
    }
    // Entities in comments and CDATA are not references.
    std::string commented = kBase;
    commented.replace(commented.find("<camera>"), 8, "<!-- &nbsp; & --><camera>");
    EXPECT_NO_THROW(readConfigString(commented, "t.xml"));
}

TEST(ConfigErrors, IsAnAvatarError) {
    EXPECT_THROW(readConfigString("<avatar version=\"1\"/>"), Error);
}

TEST(ConfigErrors, DefaultSourceName) {
    try {
        readConfigString("<avatar version=\"1\"/>");
        ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
        EXPECT_STREQ(e.what(), "<string>:1: /avatar: missing required element <camera>");
        EXPECT_EQ(e.source(), "<string>");
        EXPECT_EQ(e.line(), 1);
        EXPECT_EQ(e.elementPath(), "/avatar");
        EXPECT_EQ(e.problem(), "missing required element <camera>");
    }
}

// ---- validateConfig on configurations built in code ----------------------

struct BadConfig {
    const char* what;
    void (*apply)(AvatarConfig&);
    std::string expected;
};

std::ostream& operator<<(std::ostream& os, const BadConfig& b) {
    return os << b.what;
}

const double kNan = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

const std::vector<BadConfig> kBadConfigs = {
    {"width zero", [](AvatarConfig& c) { c.camera.width = 0; },
     "<memory>:0: /avatar/camera/width: must be between 1 and 16384, got 0"},
    {"height too large", [](AvatarConfig& c) { c.camera.height = 16385; },
     "<memory>:0: /avatar/camera/height: must be between 1 and 16384, got 16385"},
    {"bit depth 0", [](AvatarConfig& c) { c.camera.bitDepth = 0; },
     "<memory>:0: /avatar/camera/bitDepth: must be between 1 and 16, got 0"},
    {"two channels", [](AvatarConfig& c) { c.camera.channels = 2; },
     "<memory>:0: /avatar/camera/channels: must be 1 or 3, got 2"},
    {"bad enum", [](AvatarConfig& c) { c.camera.bayerPattern = static_cast<BayerPattern>(9); },
     "<memory>:0: /avatar/camera/bayerPattern: is not a BayerPattern value (9)"},
    {"control character", [](AvatarConfig& c) { c.camera.leftCameraId = "a\nb"; },
     "<memory>:0: /avatar/camera/leftCameraId: must not contain control characters, got 'a\\x0ab'"},
    {"outer space", [](AvatarConfig& c) { c.camera.rightCameraId = " cam"; },
     "<memory>:0: /avatar/camera/rightCameraId: must not begin or end with a space, got ' cam'"},
    {"same camera twice", [](AvatarConfig& c) { c.camera.rightCameraId = c.camera.leftCameraId; },
     "<memory>:0: /avatar/camera/rightCameraId: is the same as <leftCameraId> '0x00b09d01004a2c1f'"},
    {"feature not finite", [](AvatarConfig& c) { c.camera.features.gamma.value = kNan; },
     "<memory>:0: /avatar/camera/features/gamma/value: must be a finite number, got nan"},
    {"white balance not finite", [](AvatarConfig& c) { c.camera.features.whiteBalance.redV = kInf; },
     "<memory>:0: /avatar/camera/features/whiteBalance/redV: must be a finite number, got inf"},
    {"no targets", [](AvatarConfig& c) { c.targets.targets.clear(); },
     "<memory>:0: /avatar/targets: at least one <target> is required"},
    {"empty name", [](AvatarConfig& c) { c.targets.targets[1].name.clear(); },
     "<memory>:0: /avatar/targets/target[2]/@name: must be a non-empty name of letters, digits, '_' and '-', "
     "got ''"},
    {"duplicate name", [](AvatarConfig& c) { c.targets.targets[1].name = "duck_1"; },
     "<memory>:0: /avatar/targets/target[2]/@name: duplicate target name 'duck_1' (also target[1])"},
    {"bad filter", [](AvatarConfig& c) { c.targets.targets[0].filter = static_cast<ColorFilterMethod>(5); },
     "<memory>:0: /avatar/targets/target[1]/filter: is not a ColorFilterMethod value (5)"},
    {"ratio min above max", [](AvatarConfig& c) { c.targets.targets[0].redGreen = {2, 1}; },
     "<memory>:0: /avatar/targets/target[1]/redGreen: min 2 is above max 1"},
    {"ratio infinite", [](AvatarConfig& c) { c.targets.targets[1].blueGreen.max = kInf; },
     "<memory>:0: /avatar/targets/target[2]/blueGreen/max: must be a finite number, got inf"},
    {"negative brightness", [](AvatarConfig& c) { c.targets.targets[0].brightness = Range{-1, 5}; },
     "<memory>:0: /avatar/targets/target[1]/brightness/min: must be >= 0, got -1"},
    {"negative size", [](AvatarConfig& c) { c.targets.targets[0].sizeMm = Range{-1, 50}; },
     "<memory>:0: /avatar/targets/target[1]/sizeMm/min: must be >= 0, got -1"},
    {"infinite size", [](AvatarConfig& c) { c.targets.targets[1].sizeMm = Range{10, std::numeric_limits<double>::infinity()}; },
     "<memory>:0: /avatar/targets/target[2]/sizeMm/max: must be a finite number, got inf"},
    {"brightness bands on an hsv filter",
     [](AvatarConfig& c) { c.targets.targets[0].brightnessBands = {BrightnessBand{{0, 9}, {1, 2}, {1, 2}, {0, 1}}}; },
     "<memory>:0: /avatar/targets/target[1]/brightnessBands: brightness bands need <filter> rgb_ratio"},
    {"brightness band reversed",
     [](AvatarConfig& c) { c.targets.targets[1].brightnessBands = {BrightnessBand{{0, 9}, {2, 1}, {1, 2}, {0, 1}}}; },
     "<memory>:0: /avatar/targets/target[2]/brightnessBands/band[1]/redGreen: min 2 is above max 1"},
    {"veil on an hsv filter",
     [](AvatarConfig& c) { c.targets.targets[0].veil = Veil{{0.7, 1, 1}, 0.3, std::nullopt, std::nullopt}; },
     "<memory>:0: /avatar/targets/target[1]/veil: a veil needs <filter> rgb_ratio"},
    {"veil without green",
     [](AvatarConfig& c) { c.targets.targets[1].veil = Veil{{0.7, 0, 1}, 0.3, std::nullopt, std::nullopt}; },
     "<memory>:0: /avatar/targets/target[2]/veil/colourRgb: G (component 2) must be > 0, got 0"},
    {"veil's ranges reversed",
     [](AvatarConfig& c) { c.targets.targets[1].veil = Veil{{0.7, 1, 1}, 0.3, Range{2, 1}, std::nullopt}; },
     "<memory>:0: /avatar/targets/target[2]/veil/redGreen: min 2 is above max 1"},
    {"water on an hsv filter",
     [](AvatarConfig& c) { c.targets.targets[0].water = Water{{0.2, 0.03, 0.08}, 5.0, std::nullopt, std::nullopt}; },
     "<memory>:0: /avatar/targets/target[1]/water: a water needs <filter> rgb_ratio"},
    {"water absorbing less than nothing",
     [](AvatarConfig& c) { c.targets.targets[1].water = Water{{0.2, -0.03, 0.08}, 5.0, std::nullopt, std::nullopt}; },
     "<memory>:0: /avatar/targets/target[2]/water/attenuationPerM: component 2 must be between 0 and 1000, got -0.03"},
    {"water without a path",
     [](AvatarConfig& c) { c.targets.targets[1].water = Water{{0.2, 0.03, 0.08}, 0.0, std::nullopt, std::nullopt}; },
     "<memory>:0: /avatar/targets/target[2]/water/maxPathM: must be above 0 and at most 1000 m, got 0"},
    {"water's ranges reversed",
     [](AvatarConfig& c) { c.targets.targets[1].water = Water{{0.2, 0.03, 0.08}, 5.0, std::nullopt, Range{0.3, 0.2}}; },
     "<memory>:0: /avatar/targets/target[2]/water/blueGreen: min 0.3 is above max 0.2"},
    {"hue above 360", [](AvatarConfig& c) { c.targets.targets[0].hsv.hue.max = 400; },
     "<memory>:0: /avatar/targets/target[1]/hsv/hue/max: must be between 0 and 360, got 400"},
    {"saturation reversed", [](AvatarConfig& c) { c.targets.targets[0].hsv.saturation = {0.9, 0.1}; },
     "<memory>:0: /avatar/targets/target[1]/hsv/saturation: min 0.9 is above max 0.1"},
    {"kernel even", [](AvatarConfig& c) { c.targets.targets[0].erodeKernelSize = 4; },
     "<memory>:0: /avatar/targets/target[1]/erodeKernelSize: must be odd, got 4"},
    {"kernel too large", [](AvatarConfig& c) { c.targets.targets[0].erodeKernelSize = 33; },
     "<memory>:0: /avatar/targets/target[1]/erodeKernelSize: must be between 1 and 31, got 33"},
    {"area ratio above 1", [](AvatarConfig& c) { c.targets.targets[0].areaRatio.max = 1.5; },
     "<memory>:0: /avatar/targets/target[1]/areaRatio/max: must be between 0 and 1, got 1.5"},
    {"negative aspect ratio", [](AvatarConfig& c) { c.targets.targets[1].aspectRatio.min = -0.5; },
     "<memory>:0: /avatar/targets/target[2]/aspectRatio/min: must be >= 0, got -0.5"},
    {"window below the image", [](AvatarConfig& c) { c.targets.targets[0].window.height = 760; },
     "<memory>:0: /avatar/targets/target[1]/window/height: y + height = 768 exceeds the image height 767"},
    {"negative window x", [](AvatarConfig& c) { c.targets.targets[0].window.x = -1; },
     "<memory>:0: /avatar/targets/target[1]/window/x: must be between 0 and 16384, got -1"},
    {"bad method", [](AvatarConfig& c) { c.match.method = static_cast<MatchMethod>(7); },
     "<memory>:0: /avatar/match/method: is not a MatchMethod value (7)"},
    {"bad repeat policy", [](AvatarConfig& c) { c.match.repeats = static_cast<RepeatMatchPolicy>(5); },
     "<memory>:0: /avatar/match/repeats: is not a RepeatMatchPolicy value (5)"},
    {"box reversed", [](AvatarConfig& c) { c.match.boxDxMax = -20; },
     "<memory>:0: /avatar/match/box/dx: min -12.5 is above max -20"},
    // The box is open (dxMin < dx < dxMax): equal limits admit no pair at all.
    {"box dx empty", [](AvatarConfig& c) { c.match.boxDxMax = c.match.boxDxMin; },
     "<memory>:0: /avatar/match/box/dx: min -12.5 equals max; the range must not be empty"},
    {"box dy empty", [](AvatarConfig& c) { c.match.boxDyMin = c.match.boxDyMax; },
     "<memory>:0: /avatar/match/box/dy: min 7.875 equals max; the range must not be empty"},
    {"epipolar distance zero", [](AvatarConfig& c) { c.match.maxEpipolarDistancePx = 0; },
     "<memory>:0: /avatar/match/epipolarLine/maxDistancePx: must be > 0, got 0"},
    {"range from zero", [](AvatarConfig& c) { c.match.minRangeMm = 0; },
     "<memory>:0: /avatar/match/epipolarLine/rangeMm/min: must be > 0, got 0"},
    {"range reversed", [](AvatarConfig& c) { c.match.maxRangeMm = 100; },
     "<memory>:0: /avatar/match/epipolarLine/rangeMm: min 350 is above max 100"},
    {"range empty", [](AvatarConfig& c) { c.match.maxRangeMm = c.match.minRangeMm; },
     "<memory>:0: /avatar/match/epipolarLine/rangeMm: min 350 equals max; the range must not be empty"},
    {"no shape weight", [](AvatarConfig& c) { c.match.shape.magnitudeWeight = c.match.shape.directionWeight = 0; },
     "<memory>:0: /avatar/match/shape: magnitudeWeight and directionWeight must not both be 0"},
    {"area ratio limit below 1", [](AvatarConfig& c) { c.match.shape.maxAreaRatio = 0.5; },
     "<memory>:0: /avatar/match/shape/maxAreaRatio: must be >= 1, got 0.5"},
    {"shape error zero", [](AvatarConfig& c) { c.match.shape.maxError = 0; },
     "<memory>:0: /avatar/match/shape/maxError: must be > 0, got 0"},
    {"negative focal length", [](AvatarConfig& c) { c.stereo.left.fc[0] = -1049; },
     "<memory>:0: /avatar/stereo/left/fc: component 1 must be between 1 and 1e+06, got -1049"},
    {"principal point below the image", [](AvatarConfig& c) { c.stereo.right.cc[1] = 800; },
     "<memory>:0: /avatar/stereo/right/cc: component 2 (y, image height 767) must be between 0 and 767, got 800"},
    {"distortion not finite", [](AvatarConfig& c) { c.stereo.right.kc[4] = kNan; },
     "<memory>:0: /avatar/stereo/right/kc: component 5 must be a finite number, got nan"},
    {"negative standard error", [](AvatarConfig& c) {
         c.stereo.uncertainty = CalibrationUncertainty{};
         c.stereo.uncertainty->right.kc[1] = -0.1;
     },
     "<memory>:0: /avatar/stereo/uncertainty/right/kc: component 2 must be between 0 and 1000, got -0.1"},
    {"standard error not finite", [](AvatarConfig& c) {
         c.stereo.uncertainty = CalibrationUncertainty{};
         c.stereo.uncertainty->translationMm[2] = kNan;
     },
     "<memory>:0: /avatar/stereo/uncertainty/translationMm: component 3 must be a finite number, got nan"},
    {"skew not finite", [](AvatarConfig& c) { c.stereo.left.alphaC = -kInf; },
     "<memory>:0: /avatar/stereo/left/alphaC: must be a finite number, got -inf"},
    {"om not finite", [](AvatarConfig& c) { c.stereo.om[1] = kInf; },
     "<memory>:0: /avatar/stereo/om: component 2 must be a finite number, got inf"},
    {"scaled rotation", [](AvatarConfig& c) { c.stereo.baseTVision->rotation = {2, 0, 0, 0, 2, 0, 0, 0, 2}; },
     "<memory>:0: /avatar/stereo/baseTVision/rotation: is not a rotation matrix: largest element of |R R^T - I| "
     "is 3, more than 0.001"},
    {"registration translation not finite", [](AvatarConfig& c) { c.stereo.baseTVision->translationMm[0] = kNan; },
     "<memory>:0: /avatar/stereo/baseTVision/translationMm: component 1 must be a finite number, got nan"},
    {"gain zero", [](AvatarConfig& c) { c.lighting.gainsRgb[2] = 0; },
     "<memory>:0: /avatar/lighting/frameAverage/gainsRgb: component 3 must be > 0, got 0"},
    {"centre not finite", [](AvatarConfig& c) { c.lighting.patternCentrePx[0] = kNan; },
     "<memory>:0: /avatar/lighting/pattern/centrePx: component 1 must be a finite number, got nan"},
    {"negative coefficient", [](AvatarConfig& c) { c.lighting.green.coefficient = -1; },
     "<memory>:0: /avatar/lighting/pattern/green/coefficient: must be > 0, got -1"},
    {"exponent not finite", [](AvatarConfig& c) { c.lighting.blue.exponent = kInf; },
     "<memory>:0: /avatar/lighting/pattern/blue/exponent: must be a finite number, got inf"},
    {"template path with a tab", [](AvatarConfig& c) { c.lighting.templateImagePath = "a\tb.exr"; },
     "<memory>:0: /avatar/lighting/pattern/templateImage: must not contain control characters, got 'a\\x09b.exr'"},
    {"bad target shape", [](AvatarConfig& c) { c.targets.targets[1].shape = static_cast<TargetShape>(7); },
     "<memory>:0: /avatar/targets/target[2]/shape: is not a TargetShape value (7)"},
    {"empty stage name", [](AvatarConfig& c) { c.analysis.stages[2].clear(); },
     "<memory>:0: /avatar/analysis/stages: stage '' is not a name of lower-case letters, digits and '_'"},
    {"stage name with a space", [](AvatarConfig& c) { c.analysis.stages[0] = "color filter"; },
     "<memory>:0: /avatar/analysis/stages: stage 'color filter' is not a name of lower-case letters, digits and '_'"},
    {"no stages", [](AvatarConfig& c) { c.analysis.stages.clear(); },
     "<memory>:0: /avatar/analysis/stages: at least one stage is required"},
    {"bad centroid mode", [](AvatarConfig& c) { c.analysis.centroid = static_cast<CentroidMode>(-1); },
     "<memory>:0: /avatar/analysis/centroid: is not a CentroidMode value (-1)"},
    {"negative contrast", [](AvatarConfig& c) { c.analysis.visibility.minContrast = -0.01; },
     "<memory>:0: /avatar/analysis/visibility/minContrast: must be between 0 and 1, got -0.01"},
};

class BadConfigTest : public ::testing::TestWithParam<BadConfig> {};

TEST_P(BadConfigTest, IsRejectedWithItsMessage) {
    AvatarConfig c = test::unusualConfig();
    GetParam().apply(c);
    try {
        validateConfig(c);
        ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
        EXPECT_EQ(std::string(e.what()), GetParam().expected);
        EXPECT_EQ(e.line(), 0);
    }
    // Writing validates first, with the same message.
    try {
        writeConfigString(c);
        ADD_FAILURE() << "written";
    } catch (const ConfigError& e) {
        EXPECT_EQ(std::string(e.what()), GetParam().expected);
    }
}

// The checks of one part that the algorithms call (the matcher, the lighting
// corrector, the colour filter, the analysis) are the validator's own: each
// rejects what validateConfig rejects in its part, with the same message
// (a target type is named by its name instead of its index). The image-size
// rules (principal point, search window) need the camera and are left to
// validateConfig.
TEST_P(BadConfigTest, ThePartsCheckGivesTheSameMessage) {
    AvatarConfig c = test::unusualConfig();
    GetParam().apply(c);
    const std::string& expected = GetParam().expected;
    const auto messageOf = [](auto check) -> std::string {
        try {
            check();
        } catch (const ConfigError& e) {
            return e.what();
        }
        return "accepted";
    };
    const auto startsWith = [&](const char* prefix) { return expected.rfind(prefix, 0) == 0; };
    if (expected.find("/cc: ") != std::string::npos || expected.find("/window") != std::string::npos) {
        GTEST_SKIP() << "needs the image size";
    } else if (startsWith("<memory>:0: /avatar/match")) {
        EXPECT_EQ(messageOf([&] { validateMatchConfig(c.match); }), expected);
    } else if (startsWith("<memory>:0: /avatar/stereo")) {
        EXPECT_EQ(messageOf([&] { validateStereoConfig(c.stereo); }), expected);
    } else if (startsWith("<memory>:0: /avatar/lighting")) {
        EXPECT_EQ(messageOf([&] { validateLightingConfig(c.lighting); }), expected);
    } else if (startsWith("<memory>:0: /avatar/analysis")) {
        EXPECT_EQ(messageOf([&] { validateAnalysisConfig(c.analysis); }), expected);
    } else if (startsWith("<memory>:0: /avatar/targets/target[")) {
        const std::size_t open = expected.find('[') + 1;
        const std::size_t index = std::stoul(expected.substr(open)) - 1;
        if (index >= c.targets.targets.size() || expected.find("duplicate") != std::string::npos)
            GTEST_SKIP() << "a rule of the target list, not of one type";
        const TargetType& type = c.targets.targets[index];
        const std::string byName = expected.substr(0, open) + "@name='" + type.name + "'" +
                                   expected.substr(expected.find(']', open));
        EXPECT_EQ(messageOf([&] { validateTargetType(type); }), byName);
    } else {
        GTEST_SKIP() << "no part check for this section";
    }
}

INSTANTIATE_TEST_SUITE_P(Table, BadConfigTest, ::testing::ValuesIn(kBadConfigs));

}  // namespace
}  // namespace avatar
