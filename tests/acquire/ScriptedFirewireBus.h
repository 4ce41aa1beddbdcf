#pragma once
// A FireWire bus for tests: a real implementation of the FirewireBus seam,
// driven by a script of events (enumeration results, frames, timeouts,
// failures) and recording every call it receives as one line of text, e.g.
//   "enumerate", "reset", "open 0x00b09d01004a2c1f", "format7 0x00b09d01004a2c1f 8x4 RAW16",
//   "feature 0x00b09d01004a2c1f gain 200 auto", "whitebalance 0x00b09d01004a2c1f 80/60 manual",
//   "start 0x00b09d01004a2c1f 4", "dequeue 0x...", "enqueue 0x... 2", "stop 0x...", "close 0x..."
// Its cameras own real DMA-like buffers and check the buffer discipline: a
// dequeue with no free buffer, an enqueue of a buffer that is not dequeued, or
// any call on a closed camera is a violation the tests assert never happens.
#include "FirewireBus.h"

#include <cstdint>
#include <cstring>
#include <deque>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace avatar::test {

/// One thing a camera does when dequeued.
struct FrameEvent {
    enum class Kind { Frame, Timeout, Failure };
    Kind kind{Kind::Frame};
    std::int64_t timestampUs{0};
    std::uint16_t fill{0};  ///< sample (x, y, channel c) = fill + x + 2y + 10c (masked to the container)
    std::string detail;
};

inline FrameEvent frameAt(std::int64_t timestampUs, std::uint16_t fill) {
    return {FrameEvent::Kind::Frame, timestampUs, fill, {}};
}
inline FrameEvent timeoutEvent() { return {FrameEvent::Kind::Timeout, 0, 0, {}}; }
inline FrameEvent failureEvent(std::string detail) { return {FrameEvent::Kind::Failure, 0, 0, std::move(detail)}; }

inline Enumeration found(std::vector<FirewireGuid> guids) { return {BusStatus::ok(), std::move(guids)}; }
inline Enumeration enumerationFails(BusStatus::Code code, std::string detail) {
    return {BusStatus::error(code, std::move(detail)), {}};
}

/// The expected sample of a scripted frame.
inline std::uint32_t expectedSample(std::uint16_t fill, int x, int y, int channel, int bytesPerSample) {
    const std::uint32_t v = static_cast<std::uint32_t>(fill) + static_cast<std::uint32_t>(x) +
                            2u * static_cast<std::uint32_t>(y) + 10u * static_cast<std::uint32_t>(channel);
    return bytesPerSample == 1 ? (v & 0xffu) : (v & 0xffffu);
}

/// Shared between the test and the bus it hands to AvatarCameras.
struct BusScript {
    /// Results of successive enumerations; the last one repeats.
    std::deque<Enumeration> enumerations{found({})};
    /// Per camera, what successive dequeues give; empty: timeout.
    std::map<FirewireGuid, std::deque<FrameEvent>> frames;
    /// Calls (by line prefix) that fail, and how many more times (-1: always).
    std::map<std::string, int> failures;
    std::vector<std::string> calls;
    std::vector<std::string> violations;
    std::vector<FirewireGuid> present;  ///< as of the last enumeration; open() needs the GUID here
    std::map<FirewireGuid, int> dequeued;  ///< frames out of the ring now, per camera
    std::map<FirewireGuid, std::vector<const std::uint8_t*>> buffers;  ///< DMA buffer addresses while capturing

    /// Features a camera does not have, by config name ("gain", "whiteBalance");
    /// "<name> auto": it has the feature but no automatic mode for it.
    /// setFeature()/setWhiteBalance() say NotFound for them, getFeature() too.
    std::map<FirewireGuid, std::set<std::string>> absent;
    /// A feature as a scripted camera holds it.
    struct FeatureValue {
        std::uint32_t value{0};
        std::uint32_t redV{0};
        bool automatic{false};
    };
    /// What each camera's features are set to now, by config name.
    std::map<FirewireGuid, std::map<std::string, FeatureValue>> featureValues;
    /// What a feature in automatic mode reads back as, per camera and name:
    /// successive reads take successive values, the last one repeats (a
    /// camera's automatic control settling). Unscripted: the value last set.
    std::map<FirewireGuid, std::map<std::string, std::deque<std::uint32_t>>> autoValues;

    void failOn(const std::string& prefix, int times = -1) { failures[prefix] = times; }
    void add(FirewireGuid guid, std::vector<FrameEvent> events) {
        for (auto& e : events) frames[guid].push_back(std::move(e));
    }

    /// Records @p call; true when the script says it fails.
    bool record(const std::string& call) {
        calls.push_back(call);
        for (auto& [prefix, times] : failures) {
            if (call.compare(0, prefix.size(), prefix) != 0 || times == 0) continue;
            if (times > 0) --times;
            return true;
        }
        return false;
    }
    /// The calls from index @p from on, keeping those starting with @p prefix (all when empty).
    std::vector<std::string> callsFrom(std::size_t from, const std::string& prefix = {}) const {
        std::vector<std::string> out;
        for (std::size_t i = from; i < calls.size(); ++i)
            if (calls[i].compare(0, prefix.size(), prefix) == 0) out.push_back(calls[i]);
        return out;
    }
    int outstanding() const {
        int n = 0;
        for (const auto& [guid, count] : dequeued) n += count;
        return n;
    }
};

class ScriptedCamera final : public FirewireCamera {
public:
    ScriptedCamera(std::shared_ptr<BusScript> script, FirewireGuid guid) : s_(std::move(script)), guid_(guid) {}
    ~ScriptedCamera() override {
        s_->calls.push_back("close " + formatGuid(guid_));
        release();
    }

    FirewireGuid guid() const override { return guid_; }

    BusStatus setFormat7(const Format7Settings& f) override {
        const std::string call = "format7 " + formatGuid(guid_) + " " + std::to_string(f.width) + "x" +
                                 std::to_string(f.height) + " " + std::string(toString(f.coding));
        if (capturing_) s_->violations.push_back(call + " while capturing");
        if (s_->record(call)) return BusStatus::error(BusStatus::Code::Rejected, "scripted: mode not supported");
        format_ = f;
        return BusStatus::ok();
    }

    BusStatus setFeature(FirewireFeature feature, std::uint32_t value, bool automatic) override {
        const std::string name(toString(feature));
        const std::string call = "feature " + formatGuid(guid_) + " " + name + " " + std::to_string(value) +
                                 (automatic ? " auto" : " manual");
        if (s_->record(call)) return BusStatus::error(BusStatus::Code::Rejected, "scripted: value out of range");
        if (const BusStatus lacking = lacks(name, automatic); !lacking.isOk()) return lacking;
        auto& held = s_->featureValues[guid_][name];
        held.automatic = automatic;
        if (!automatic) held.value = value;
        return BusStatus::ok();
    }

    BusStatus setWhiteBalance(std::uint32_t blueU, std::uint32_t redV, bool automatic) override {
        const std::string call = "whitebalance " + formatGuid(guid_) + " " + std::to_string(blueU) + "/" +
                                 std::to_string(redV) + (automatic ? " auto" : " manual");
        if (s_->record(call)) return BusStatus::error(BusStatus::Code::Rejected, "scripted: value out of range");
        if (const BusStatus lacking = lacks("whiteBalance", automatic); !lacking.isOk()) return lacking;
        auto& held = s_->featureValues[guid_]["whiteBalance"];
        held.automatic = automatic;
        if (!automatic) {
            held.value = blueU;
            held.redV = redV;
        }
        return BusStatus::ok();
    }

    FeatureState getFeature(FirewireFeature feature) override { return read(std::string(toString(feature))); }

    FeatureState getWhiteBalance() override { return read("whiteBalance"); }

    BusStatus startCapture(std::uint32_t dmaBuffers) override {
        const std::string call = "start " + formatGuid(guid_) + " " + std::to_string(dmaBuffers);
        if (capturing_) s_->violations.push_back(call + " while capturing");
        if (s_->record(call)) return BusStatus::error(BusStatus::Code::Failure, "scripted: no bandwidth");
        rowBytes_ = static_cast<std::size_t>(format_.width) * static_cast<std::size_t>(bytesPerPixel(format_.coding));
        stride_ = rowBytes_ + 8;  // padded rows, so the stride is honoured
        buffers_.assign(dmaBuffers, std::vector<std::uint8_t>(stride_ * static_cast<std::size_t>(format_.height), 0xEE));
        inUse_.assign(dmaBuffers, false);
        capturing_ = true;
        auto& addresses = s_->buffers[guid_];
        addresses.clear();
        for (const auto& b : buffers_) addresses.push_back(b.data());
        return BusStatus::ok();
    }

    DequeueResult dequeue(std::chrono::milliseconds /*timeout*/) override {
        const std::string call = "dequeue " + formatGuid(guid_);
        if (!capturing_) s_->violations.push_back(call + " while not capturing");
        if (s_->record(call)) return {BusStatus::error(BusStatus::Code::Failure, "scripted: iso error"), {}};
        auto& events = s_->frames[guid_];
        if (events.empty()) return {BusStatus::error(BusStatus::Code::Timeout, "scripted: nothing"), {}};
        const FrameEvent e = events.front();
        events.pop_front();
        if (e.kind == FrameEvent::Kind::Timeout)
            return {BusStatus::error(BusStatus::Code::Timeout, "scripted: camera silent"), {}};
        if (e.kind == FrameEvent::Kind::Failure) return {BusStatus::error(BusStatus::Code::Failure, e.detail), {}};
        std::size_t index = 0;
        while (index < inUse_.size() && inUse_[index]) ++index;
        if (index == inUse_.size()) {
            s_->violations.push_back(call + ": every DMA buffer is dequeued (frames not given back)");
            return {BusStatus::error(BusStatus::Code::Failure, "scripted: ring empty"), {}};
        }
        fill(buffers_[index], e.fill);
        inUse_[index] = true;
        ++s_->dequeued[guid_];
        FirewireFrame f;
        f.data = buffers_[index].data();
        f.bytes = buffers_[index].size();
        f.width = format_.width;
        f.height = format_.height;
        f.stride = stride_;
        f.timestampUs = e.timestampUs;
        f.bufferId = static_cast<std::uint32_t>(index);
        return {BusStatus::ok(), f};
    }

    BusStatus enqueue(const FirewireFrame& frame) override {
        const std::string call = "enqueue " + formatGuid(guid_) + " " + std::to_string(frame.bufferId);
        s_->calls.push_back(call);
        if (!capturing_ || frame.bufferId >= inUse_.size() || !inUse_[frame.bufferId]) {
            s_->violations.push_back(call + ": buffer is not dequeued");
            return BusStatus::error(BusStatus::Code::NotFound, "scripted: buffer not dequeued");
        }
        inUse_[frame.bufferId] = false;
        --s_->dequeued[guid_];
        return BusStatus::ok();
    }

    BusStatus stopCapture() override {
        s_->record("stop " + formatGuid(guid_));
        release();
        return BusStatus::ok();
    }

private:
    /// NotFound when the script says this camera lacks @p name (or its automatic mode).
    BusStatus lacks(const std::string& name, bool automatic) const {
        const auto it = s_->absent.find(guid_);
        if (it == s_->absent.end()) return BusStatus::ok();
        if (it->second.count(name) > 0)
            return BusStatus::error(BusStatus::Code::NotFound, "scripted: the camera has no " + name + " feature");
        if (automatic && it->second.count(name + " auto") > 0)
            return BusStatus::error(BusStatus::Code::NotFound, "scripted: the camera has no automatic mode for " + name);
        return BusStatus::ok();
    }

    FeatureState read(const std::string& name) {
        FeatureState state;
        state.status = lacks(name, false);
        if (!state.status.isOk()) return state;
        const auto it = s_->absent.find(guid_);
        state.autoAvailable = it == s_->absent.end() || it->second.count(name + " auto") == 0;
        const auto& held = s_->featureValues[guid_][name];
        state.automatic = held.automatic;
        state.value = held.value;
        state.redV = held.redV;
        if (held.automatic) {
            auto& script = s_->autoValues[guid_][name];
            if (!script.empty()) {
                state.value = script.front();
                if (script.size() > 1) script.pop_front();
            }
        }
        return state;
    }

    void release() {
        if (!capturing_) return;
        capturing_ = false;
        for (const bool used : inUse_)
            if (used) --s_->dequeued[guid_];
        buffers_.clear();
        inUse_.clear();
        s_->buffers.erase(guid_);
    }

    void fill(std::vector<std::uint8_t>& buffer, std::uint16_t value) const {
        const int channels = format_.coding == PixelCoding::Rgb8 || format_.coding == PixelCoding::Rgb16 ? 3 : 1;
        const int bytes = bytesPerPixel(format_.coding) / channels;
        for (int y = 0; y < format_.height; ++y) {
            std::uint8_t* row = buffer.data() + static_cast<std::size_t>(y) * stride_;
            for (int x = 0; x < format_.width; ++x)
                for (int c = 0; c < channels; ++c) {
                    const std::uint32_t v = expectedSample(value, x, y, c, bytes);
                    std::uint8_t* p = row + static_cast<std::size_t>((x * channels + c) * bytes);
                    if (bytes == 1) {
                        *p = static_cast<std::uint8_t>(v);
                    } else {
                        const auto v16 = static_cast<std::uint16_t>(v);
                        std::memcpy(p, &v16, 2);
                    }
                }
        }
    }

    std::shared_ptr<BusScript> s_;
    FirewireGuid guid_;
    Format7Settings format_;
    bool capturing_{false};
    std::size_t rowBytes_{0};
    std::size_t stride_{0};
    std::vector<std::vector<std::uint8_t>> buffers_;
    std::vector<bool> inUse_;
};

class ScriptedBus final : public FirewireBus {
public:
    explicit ScriptedBus(std::shared_ptr<BusScript> script) : s_(std::move(script)) {}
    std::string name() const override { return "scripted"; }

    std::string describe(FirewireGuid guid) override {
        for (const FirewireGuid g : s_->present)
            if (g == guid) return "Scripted IIDC camera";
        return {};
    }

    Enumeration enumerate() override {
        s_->calls.push_back("enumerate");
        Enumeration e = s_->enumerations.front();
        if (s_->enumerations.size() > 1) s_->enumerations.pop_front();
        s_->present = e.status.isOk() ? e.guids : std::vector<FirewireGuid>{};
        return e;
    }

    OpenResult open(FirewireGuid guid) override {
        const std::string call = "open " + formatGuid(guid);
        bool present = false;
        for (const FirewireGuid g : s_->present) present = present || g == guid;
        if (s_->record(call) || !present)
            return {BusStatus::error(BusStatus::Code::NotFound, "scripted: no such camera"), nullptr};
        return {BusStatus::ok(), std::make_unique<ScriptedCamera>(s_, guid)};
    }

    BusStatus resetBus() override {
        if (s_->record("reset")) return BusStatus::error(BusStatus::Code::NotFound, "scripted: nothing to reset through");
        return BusStatus::ok();
    }

private:
    std::shared_ptr<BusScript> s_;
};

}  // namespace avatar::test
