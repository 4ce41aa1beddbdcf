#include "Formats.h"

#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <vector>

namespace avatar::calibrate {

namespace fs = std::filesystem;

namespace {

cv::Mat kOf(const CameraIntrinsics& c) { return cv::Mat(cameraMatrix(c)); }
cv::Mat dOf(const CameraIntrinsics& c) {
    return (cv::Mat_<double>(1, 5) << c.kc[0], c.kc[1], c.kc[2], c.kc[3], c.kc[4]);
}

CameraIntrinsics intrinsicsOf(const cv::Mat& k, const cv::Mat& d, const std::string& where) {
    if (k.rows != 3 || k.cols != 3) throw FormatError(where + ": the camera matrix is not 3x3");
    cv::Mat kd, dd;
    k.convertTo(kd, CV_64F);
    d.convertTo(dd, CV_64F);
    if (dd.total() < 4 || dd.total() > 5)
        throw FormatError(where + ": " + std::to_string(dd.total()) +
                          " distortion coefficients; the plumb-bob model has 4 or 5 (k1 k2 p1 p2 [k3])");
    CameraIntrinsics in;
    in.fc = {kd.at<double>(0, 0), kd.at<double>(1, 1)};
    in.cc = {kd.at<double>(0, 2), kd.at<double>(1, 2)};
    in.alphaC = kd.at<double>(0, 1) / kd.at<double>(0, 0);
    for (std::size_t i = 0; i < dd.total(); ++i) in.kc[i] = dd.at<double>(static_cast<int>(i));
    return in;
}

struct Rectification {
    cv::Mat r1, r2, p1, p2, q;
};

/// cv::stereoRectify of the calibration, translation scaled by @p scale (1: mm, 1e-3: m).
Rectification rectify(const StereoSystemConfig& s, cv::Size size, double scale) {
    const RigidTransform rTl = rightTLeft(s);
    const cv::Mat r(rotationMatrix(rTl));
    const cv::Mat t = cv::Mat(translationVector(rTl)) * scale;
    Rectification out;
    cv::stereoRectify(kOf(s.left), dOf(s.left), kOf(s.right), dOf(s.right), size, r, t, out.r1, out.r2, out.p1,
                      out.p2, out.q, cv::CALIB_ZERO_DISPARITY, 0);
    return out;
}

void requireSize(cv::Size size, const char* what) {
    if (size.width <= 0 || size.height <= 0)
        throw InvalidArgument(std::string(what) + ": the image size is unknown (give a configuration with its camera size)");
}

// ---- OpenCV FileStorage ------------------------------------------------

cv::Mat firstOf(const cv::FileStorage& fs, std::initializer_list<const char*> keys, const std::string& file,
                std::string& found) {
    for (const char* key : keys) {
        cv::Mat m;
        fs[key] >> m;
        if (!m.empty()) {
            found = key;
            return m;
        }
    }
    std::string names;
    for (const char* key : keys) names += (names.empty() ? "" : ", ") + std::string(key);
    throw FormatError(file + ": none of the keys " + names + " holds a matrix");
}

ImportedCalibration importOpenCv(const std::string& file) {
    cv::FileStorage fs;
    try {
        fs.open(file, cv::FileStorage::READ);
    } catch (const cv::Exception& e) {
        throw FormatError(file + ": not an OpenCV FileStorage file: " + e.msg);
    }
    if (!fs.isOpened()) throw IoError("cannot read calibration file '" + file + "'");
    std::string key;
    ImportedCalibration out;
    out.format = "opencv";
    const cv::Mat kl = firstOf(fs, {"camera_matrix_left", "M1", "K1", "cameraMatrix1"}, file, key);
    const cv::Mat dl = firstOf(fs, {"dist_coeffs_left", "D1", "distCoeffs1"}, file, key);
    const cv::Mat kr = firstOf(fs, {"camera_matrix_right", "M2", "K2", "cameraMatrix2"}, file, key);
    const cv::Mat dr = firstOf(fs, {"dist_coeffs_right", "D2", "distCoeffs2"}, file, key);
    const cv::Mat r = firstOf(fs, {"R"}, file, key);
    const cv::Mat t = firstOf(fs, {"T"}, file, key);
    out.stereo.left = intrinsicsOf(kl, dl, file + " (left camera)");
    out.stereo.right = intrinsicsOf(kr, dr, file + " (right camera)");
    cv::Mat rd, td;
    r.convertTo(rd, CV_64F);
    t.convertTo(td, CV_64F);
    if (rd.total() != 9 && rd.total() != 3) throw FormatError(file + ": R is neither a 3x3 matrix nor a rotation vector");
    if (td.total() != 3) throw FormatError(file + ": T does not have 3 elements");
    cv::Vec3d om;
    if (rd.total() == 9) cv::Rodrigues(rd.reshape(1, 3), om);
    else om = cv::Vec3d(rd.at<double>(0), rd.at<double>(1), rd.at<double>(2));
    out.stereo.om = {om[0], om[1], om[2]};
    out.stereo.translationMm = {td.at<double>(0), td.at<double>(1), td.at<double>(2)};
    cv::Mat sl, sr, so, st;
    fs["std_intrinsics_left"] >> sl;
    fs["std_intrinsics_right"] >> sr;
    fs["std_om"] >> so;
    fs["std_T"] >> st;
    if (sl.total() == 9 && sr.total() == 9 && so.total() == 3 && st.total() == 3) {
        CalibrationUncertainty u;
        for (const auto& [m, in] : {std::pair<const cv::Mat&, IntrinsicsUncertainty&>{sl, u.left}, {sr, u.right}}) {
            cv::Mat d;
            m.convertTo(d, CV_64F);
            in.fc = {d.at<double>(0), d.at<double>(1)};
            in.cc = {d.at<double>(2), d.at<double>(3)};
            in.kc = {d.at<double>(4), d.at<double>(5), d.at<double>(6), d.at<double>(7), d.at<double>(8)};
        }
        cv::Mat o, t2;
        so.convertTo(o, CV_64F);
        st.convertTo(t2, CV_64F);
        u.om = {o.at<double>(0), o.at<double>(1), o.at<double>(2)};
        u.translationMm = {t2.at<double>(0), t2.at<double>(1), t2.at<double>(2)};
        out.stereo.uncertainty = u;
    }
    int width = 0, height = 0;
    fs["image_width"] >> width;
    fs["image_height"] >> height;
    out.imageSize = cv::Size(width, height);
    return out;
}

// ---- ROS camera_info -----------------------------------------------------

struct RosCamera {
    cv::Size size;
    cv::Mat k, d, r, p;
};

cv::Mat rosMatrix(const YAML::Node& node, const char* key, int rows, int cols, const std::string& file) {
    const YAML::Node m = node[key];
    if (!m) throw FormatError(file + ": no '" + std::string(key) + "'");
    const YAML::Node data = m["data"];
    if (!data || !data.IsSequence() || data.size() != static_cast<std::size_t>(rows * cols))
        throw FormatError(file + ": '" + std::string(key) + "' must have " + std::to_string(rows * cols) +
                          " numbers in data");
    cv::Mat out(rows, cols, CV_64F);
    for (int i = 0; i < rows * cols; ++i) out.at<double>(i / cols, i % cols) = data[static_cast<std::size_t>(i)].as<double>();
    return out;
}

RosCamera readRos(const std::string& file) {
    YAML::Node root;
    try {
        root = YAML::LoadFile(file);
    } catch (const YAML::BadFile&) {
        throw IoError("cannot read ROS camera_info file '" + file + "'");
    } catch (const YAML::Exception& e) {
        throw FormatError(file + ": not YAML: " + e.what());
    }
    try {
        RosCamera c;
        c.size = cv::Size(root["image_width"].as<int>(0), root["image_height"].as<int>(0));
        if (root["distortion_model"] && root["distortion_model"].as<std::string>() != "plumb_bob")
            throw FormatError(file + ": distortion_model '" + root["distortion_model"].as<std::string>() +
                              "' is not plumb_bob");
        c.k = rosMatrix(root, "camera_matrix", 3, 3, file);
        const YAML::Node d = root["distortion_coefficients"]["data"];
        if (!d || !d.IsSequence()) throw FormatError(file + ": no distortion_coefficients data");
        c.d = cv::Mat(1, static_cast<int>(d.size()), CV_64F);
        for (std::size_t i = 0; i < d.size(); ++i) c.d.at<double>(static_cast<int>(i)) = d[i].as<double>();
        c.r = rosMatrix(root, "rectification_matrix", 3, 3, file);
        c.p = rosMatrix(root, "projection_matrix", 3, 4, file);
        return c;
    } catch (const YAML::Exception& e) {
        throw FormatError(file + ": " + e.what());
    }
}

ImportedCalibration importRos(const std::string& leftFile, const std::string& rightFile) {
    const RosCamera l = readRos(leftFile), r = readRos(rightFile);
    ImportedCalibration out;
    out.format = "ros";
    out.stereo.left = intrinsicsOf(l.k, l.d, leftFile);
    out.stereo.right = intrinsicsOf(r.k, r.d, rightFile);
    // X_rect = R1 X_left = R2 X_right + (0, 0, 0), and the right rectified
    // camera sits at -t_rect: X_right_rect = X_left_rect + t_rect with
    // t_rect = (P2[0][3] / P2[0][0], P2[1][3] / P2[1][1], 0), in metres.
    const cv::Mat rotation = r.r.t() * l.r;
    const cv::Mat tRect = (cv::Mat_<double>(3, 1) << r.p.at<double>(0, 3) / r.p.at<double>(0, 0),
                           r.p.at<double>(1, 3) / r.p.at<double>(1, 1), 0.0);
    const cv::Mat t = r.r.t() * tRect * 1000.0;  // m -> mm
    cv::Vec3d om;
    cv::Rodrigues(rotation, om);
    out.stereo.om = {om[0], om[1], om[2]};
    out.stereo.translationMm = {t.at<double>(0), t.at<double>(1), t.at<double>(2)};
    out.imageSize = l.size;
    return out;
}

// ---- Bouguet toolbox text ------------------------------------------------

/// name -> numbers, and name -> standard errors, from lines such as
///   fc_left = [ 1049.13 ; 1050.38 ];            (Calib_Results_stereo.m)
///   fc_left_error = [ 0.67 ; 0.68 ];
///   fc_left = [ 1049.13  1050.38 ] +/- [ 0.67  0.68 ]   (the printed results; also with "±")
struct BouguetText {
    std::map<std::string, std::vector<double>> values;
    std::map<std::string, std::vector<double>> errors;
};

std::vector<double> numbersIn(const std::string& text) {
    std::vector<double> out;
    std::string cleaned = text;
    for (char& c : cleaned)
        if (c == ';' || c == ',') c = ' ';
    std::istringstream in(cleaned);
    for (double v; in >> v;) out.push_back(v);
    return out;
}

BouguetText readBouguet(const std::string& file) {
    std::ifstream in(file);
    if (!in) throw IoError("cannot read Bouguet calibration file '" + file + "'");
    static const std::regex line(R"(\b([A-Za-z_][A-Za-z0-9_]*)\s*=\s*\[([^\]]*)\]\s*(?:(?:\+/-|\xC2\xB1)\s*\[([^\]]*)\])?)");
    BouguetText out;
    for (std::string text; std::getline(in, text);) {
        std::smatch m;
        if (!std::regex_search(text, m, line)) continue;
        const std::string name = m[1];
        const std::vector<double> numbers = numbersIn(m[2]);
        const std::string suffix = "_error";
        if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
            out.errors[name.substr(0, name.size() - suffix.size())] = numbers;
        else
            out.values[name] = numbers;
        if (m[3].matched) out.errors[name] = numbersIn(m[3]);
    }
    return out;
}

std::vector<double> need(const BouguetText& b, const std::string& name, std::size_t count, const std::string& file) {
    const auto it = b.values.find(name);
    if (it == b.values.end()) throw FormatError(file + ": no '" + name + " = [ ... ]' in the Bouguet calibration");
    if (it->second.size() != count)
        throw FormatError(file + ": '" + name + "' has " + std::to_string(it->second.size()) + " numbers, expected " +
                          std::to_string(count));
    return it->second;
}

ImportedCalibration importBouguet(const std::string& file) {
    const BouguetText b = readBouguet(file);
    ImportedCalibration out;
    out.format = "bouguet";
    bool errors = true;
    CalibrationUncertainty u;
    const auto error = [&](const std::string& name, std::size_t count) {
        const auto it = b.errors.find(name);
        if (it == b.errors.end() || it->second.size() != count) {
            errors = false;
            return std::vector<double>(count, 0.0);
        }
        return it->second;
    };
    for (const auto& [side, in, un] : {std::tuple<const char*, CameraIntrinsics*, IntrinsicsUncertainty*>{
                                           "left", &out.stereo.left, &u.left},
                                       {"right", &out.stereo.right, &u.right}}) {
        const std::string s = side;
        const auto fc = need(b, "fc_" + s, 2, file), cc = need(b, "cc_" + s, 2, file), kc = need(b, "kc_" + s, 5, file);
        in->fc = {fc[0], fc[1]};
        in->cc = {cc[0], cc[1]};
        const auto alpha = b.values.find("alpha_c_" + s);
        in->alphaC = alpha != b.values.end() && alpha->second.size() == 1 ? alpha->second[0] : 0.0;
        for (std::size_t i = 0; i < 5; ++i) in->kc[i] = kc[i];
        const auto fe = error("fc_" + s, 2), ce = error("cc_" + s, 2), ke = error("kc_" + s, 5);
        un->fc = {fe[0], fe[1]};
        un->cc = {ce[0], ce[1]};
        un->kc = {ke[0], ke[1], ke[2], ke[3], ke[4]};
        const auto ae = b.errors.find("alpha_c_" + s);
        un->alphaC = ae != b.errors.end() && ae->second.size() == 1 ? ae->second[0] : 0.0;
    }
    const auto om = need(b, "om", 3, file), t = need(b, "T", 3, file);
    out.stereo.om = {om[0], om[1], om[2]};
    out.stereo.translationMm = {t[0], t[1], t[2]};
    const auto oe = error("om", 3), te = error("T", 3);
    u.om = {oe[0], oe[1], oe[2]};
    u.translationMm = {te[0], te[1], te[2]};
    if (errors) out.stereo.uncertainty = u;
    const auto nx = b.values.find("nx"), ny = b.values.find("ny");
    if (nx != b.values.end() && ny != b.values.end() && nx->second.size() == 1 && ny->second.size() == 1)
        out.imageSize = cv::Size(static_cast<int>(nx->second[0]), static_cast<int>(ny->second[0]));
    return out;
}

bool startsWith(const std::string& text, const std::string& prefix) { return text.rfind(prefix, 0) == 0; }

}  // namespace

ImportedCalibration importCalibration(const std::string& source) {
    if (const auto comma = source.find(','); comma != std::string::npos)
        return importRos(source.substr(0, comma), source.substr(comma + 1));
    std::error_code ec;
    if (fs::is_directory(source, ec)) {
        const fs::path dir(source);
        if (!fs::exists(dir / "left.yaml") || !fs::exists(dir / "right.yaml"))
            throw IoError("directory '" + source + "' holds no left.yaml and right.yaml (ROS camera_info)");
        return importRos((dir / "left.yaml").string(), (dir / "right.yaml").string());
    }
    std::ifstream in(source);
    if (!in) throw IoError("cannot read calibration file '" + source + "'");
    std::string first;
    std::getline(in, first);
    if (startsWith(first, "%YAML") || startsWith(first, "<?xml")) return importOpenCv(source);
    const std::string extension = fs::path(source).extension().string();
    if (extension == ".yaml" || extension == ".yml")
        throw FormatError(source + ": a single ROS camera_info file describes one camera; give LEFT.yaml,RIGHT.yaml "
                                   "or a directory holding left.yaml and right.yaml");
    return importBouguet(source);
}

void exportOpenCv(const StereoSystemConfig& stereo, cv::Size size, const fs::path& file) {
    requireSize(size, "--export-opencv");
    const Rectification rect = rectify(stereo, size, 1.0);
    const StereoGeometry g = stereoGeometry(stereo);
    cv::FileStorage fs(file.string(), cv::FileStorage::WRITE);
    if (!fs.isOpened()) throw IoError("cannot write '" + file.string() + "'");
    fs << "image_width" << size.width << "image_height" << size.height;
    fs << "camera_matrix_left" << kOf(stereo.left) << "dist_coeffs_left" << dOf(stereo.left);
    fs << "camera_matrix_right" << kOf(stereo.right) << "dist_coeffs_right" << dOf(stereo.right);
    fs << "R" << cv::Mat(rotationMatrix(g.rightTLeft)) << "T" << cv::Mat(translationVector(g.rightTLeft));
    fs << "E" << cv::Mat(essentialMatrix(g.rightTLeft)) << "F" << cv::Mat(fundamentalMatrix(g));
    fs << "R1" << rect.r1 << "R2" << rect.r2 << "P1" << rect.p1 << "P2" << rect.p2 << "Q" << rect.q;
    if (stereo.uncertainty) {
        // Standard errors, in calibrateCamera's order (fx fy cx cy k1 k2 p1 p2 k3) and of om and T.
        const CalibrationUncertainty& u = *stereo.uncertainty;
        for (const auto& [key, in] : {std::pair<const char*, const IntrinsicsUncertainty&>{"std_intrinsics_left", u.left},
                                      {"std_intrinsics_right", u.right}})
            fs << key << (cv::Mat_<double>(1, 9) << in.fc[0], in.fc[1], in.cc[0], in.cc[1], in.kc[0], in.kc[1], in.kc[2],
                          in.kc[3], in.kc[4]);
        fs << "std_om" << cv::Mat(cv::Vec3d(u.om[0], u.om[1], u.om[2]));
        fs << "std_T" << cv::Mat(cv::Vec3d(u.translationMm[0], u.translationMm[1], u.translationMm[2]));
    }
    fs.release();
}

void exportRos(const StereoSystemConfig& stereo, cv::Size size, const fs::path& directory) {
    requireSize(size, "--export-ros");
    std::error_code ec;
    fs::create_directories(directory, ec);
    if (ec) throw IoError("cannot create '" + directory.string() + "': " + ec.message());
    const Rectification rect = rectify(stereo, size, 1e-3);  // ROS: metres
    const auto matrix = [](YAML::Emitter& out, const char* key, const cv::Mat& m) {
        out << YAML::Key << key << YAML::Value << YAML::BeginMap;
        out << YAML::Key << "rows" << YAML::Value << m.rows << YAML::Key << "cols" << YAML::Value << m.cols;
        out << YAML::Key << "data" << YAML::Value << YAML::Flow << YAML::BeginSeq;
        for (int i = 0; i < m.rows; ++i)
            for (int j = 0; j < m.cols; ++j) out << m.at<double>(i, j);
        out << YAML::EndSeq << YAML::EndMap;
    };
    for (const auto& [name, in, r, p] :
         {std::tuple<const char*, const CameraIntrinsics&, const cv::Mat&, const cv::Mat&>{"left", stereo.left, rect.r1,
                                                                                            rect.p1},
          {"right", stereo.right, rect.r2, rect.p2}}) {
        YAML::Emitter out;
        out.SetDoublePrecision(17);
        out << YAML::BeginMap;
        out << YAML::Key << "image_width" << YAML::Value << size.width;
        out << YAML::Key << "image_height" << YAML::Value << size.height;
        out << YAML::Key << "camera_name" << YAML::Value << name;
        matrix(out, "camera_matrix", kOf(in));
        out << YAML::Key << "distortion_model" << YAML::Value << "plumb_bob";
        matrix(out, "distortion_coefficients", dOf(in));
        matrix(out, "rectification_matrix", r);
        matrix(out, "projection_matrix", p);
        out << YAML::EndMap;
        const fs::path file = directory / (std::string(name) + ".yaml");
        std::ofstream f(file, std::ios::trunc);
        f << out.c_str() << "\n";
        if (!f) throw IoError("cannot write '" + file.string() + "'");
    }
}

}  // namespace avatar::calibrate
