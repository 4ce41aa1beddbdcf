#include <avatar/common/StereoImagePair.h>
#include <avatar/config/ConfigXml.h>

#include <opencv2/core.hpp>

#include <iostream>

int main() {
    cv::Mat l(2, 4, CV_16UC1, cv::Scalar(1)), r(2, 4, CV_16UC1, cv::Scalar(2));
    avatar::StereoImagePair pair(l, r, {avatar::PixelFormat::Bayer, avatar::BayerPattern::RG, 12},
                                 {2, 5, {}, {}});
    std::cout << "pair: " << pair.describe() << "\n";

    avatar::AvatarConfig config;
    config.stereo.left.fc = {1049.13, 1050.38};
    config.targets.targets.push_back(avatar::TargetType{});
    config.targets.targets.back().name = "sample";
    const auto back = avatar::readConfigString(avatar::writeConfigString(config), "downstream");
    std::cout << "config round trip: " << (back == config ? "identical" : "different") << "\n";
    return back == config ? 0 : 1;
}
