#include "FirewireBus.h"

#include <cstdio>

namespace avatar {

std::string formatGuid(FirewireGuid guid) {
    char text[19];
    std::snprintf(text, sizeof text, "0x%016llx", static_cast<unsigned long long>(guid));
    return text;
}

std::optional<FirewireGuid> parseGuid(std::string_view text) {
    if (text.size() < 3 || text.size() > 18 || text[0] != '0' || (text[1] != 'x' && text[1] != 'X'))
        return std::nullopt;
    FirewireGuid guid = 0;
    for (const char c : text.substr(2)) {
        int digit;
        if (c >= '0' && c <= '9')
            digit = c - '0';
        else if (c >= 'a' && c <= 'f')
            digit = c - 'a' + 10;
        else if (c >= 'A' && c <= 'F')
            digit = c - 'A' + 10;
        else
            return std::nullopt;
        guid = (guid << 4) | static_cast<FirewireGuid>(digit);
    }
    return guid;
}

std::string_view toString(BusStatus::Code code) {
    switch (code) {
    case BusStatus::Code::Ok: return "ok";
    case BusStatus::Code::Timeout: return "timeout";
    case BusStatus::Code::NotFound: return "not found";
    case BusStatus::Code::Unavailable: return "unavailable";
    case BusStatus::Code::Rejected: return "rejected";
    case BusStatus::Code::Failure: return "failure";
    }
    return "unknown";
}

std::string_view toString(PixelCoding coding) {
    switch (coding) {
    case PixelCoding::Mono8: return "MONO8";
    case PixelCoding::Mono16: return "MONO16";
    case PixelCoding::Raw8: return "RAW8";
    case PixelCoding::Raw16: return "RAW16";
    case PixelCoding::Rgb8: return "RGB8";
    case PixelCoding::Rgb16: return "RGB16";
    }
    return "unknown";
}

int bytesPerPixel(PixelCoding coding) {
    switch (coding) {
    case PixelCoding::Mono8:
    case PixelCoding::Raw8: return 1;
    case PixelCoding::Mono16:
    case PixelCoding::Raw16: return 2;
    case PixelCoding::Rgb8: return 3;
    case PixelCoding::Rgb16: return 6;
    }
    return 0;
}

std::string_view toString(FirewireFeature feature) {
    switch (feature) {
    case FirewireFeature::Exposure: return "exposure";
    case FirewireFeature::Shutter: return "shutter";
    case FirewireFeature::Gain: return "gain";
    case FirewireFeature::Brightness: return "brightness";
    case FirewireFeature::Gamma: return "gamma";
    }
    return "unknown";
}

}  // namespace avatar
