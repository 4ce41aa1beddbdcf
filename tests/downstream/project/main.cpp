#include <avatar/common/StereoImagePair.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/servo/SimulatedArm.h>
#include <avatar/servo/VisualServo.h>
#include <avatar/tau/TauUnit.h>

#include <opencv2/core.hpp>

#include <iostream>
#include <string>

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

namespace {

// A loopback port on which nothing listens: bound (so no one else takes it), not listening.
int closedPort(std::uint16_t& port) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
    return fd;
}

// A manipulator controller's first step: a TAUUnit client. Connecting to a port
// where no TAUNet listens is the documented ConnectionError naming host:port.
bool tauUnitReportsClosedPort() {
    std::uint16_t port = 0;
    const int fd = closedPort(port);
    avatar::tau::TauUnitOptions options;
    options.port = port;
    options.clientName = "downstream";
    avatar::tau::TauUnit unit(options);
    bool ok = false;
    try {
        unit.connect();
    } catch (const avatar::tau::TimeoutError&) {
        std::cout << "tauunit: unexpected timeout\n";
    } catch (const avatar::tau::ConnectionError& e) {
        const std::string endpoint = "127.0.0.1:" + std::to_string(port);
        ok = e.endpoint() == endpoint && e.request() == "HELLO" &&
             std::string(e.what()).find(endpoint) != std::string::npos;
        std::cout << "tauunit: closed port gives ConnectionError for " << e.request()
                  << (ok ? " naming the endpoint" : std::string(" without the endpoint: ") + e.what()) << "\n";
    }
    ::close(fd);
    return ok && unit.timings().size() == 1 && !unit.connected();
}

// The servo a controller links: its arm interface and its state table.
bool servoLinks() {
    avatar::servo::SimulatedArmOptions options;
    options.repeatabilityMm = 0.0;
    avatar::servo::SimulatedArm arm(options);
    arm.moveTo({10.0, 0.0, 0.0});
    const bool moved = arm.motionComplete() && arm.telemetry().baseTTool.translationMm[0] == 10.0;
    const bool table = avatar::servo::nextState(avatar::servo::ServoState::ArmSampling,
                                                avatar::servo::ServoEvent::MotionComplete) ==
                       avatar::servo::ServoState::Done;
    std::cout << "servo: simulated arm " << (moved ? "moved" : "did not move") << ", state table "
              << (table ? "as documented" : "wrong") << "\n";
    return moved && table;
}

}  // namespace

int main() {
    cv::Mat l(2, 4, CV_16UC1, cv::Scalar(1)), r(2, 4, CV_16UC1, cv::Scalar(2));
    avatar::StereoImagePair pair(l, r, {avatar::PixelFormat::Bayer, avatar::BayerPattern::RG, 12},
                                 {2, 5, {}, {}});
    std::cout << "pair: " << pair.describe() << "\n";

    avatar::AvatarConfig config;
    config.stereo.left.fc = {800.0, 805.0};
    config.targets.targets.push_back(avatar::TargetType{});
    config.targets.targets.back().name = "sample";
    const auto back = avatar::readConfigString(avatar::writeConfigString(config), "downstream");
    std::cout << "config round trip: " << (back == config ? "identical" : "different") << "\n";
    const bool tauOk = tauUnitReportsClosedPort();
    const bool servoOk = servoLinks();
    return back == config && tauOk && servoOk ? 0 : 1;
}
