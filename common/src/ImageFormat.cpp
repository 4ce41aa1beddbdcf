#include <avatar/common/Error.h>
#include <avatar/common/ImageFormat.h>

#include <cstdint>
#include <cstring>

namespace avatar {

std::string_view toString(Side side) { return side == Side::Left ? "L" : "R"; }

std::string_view toString(BayerPattern pattern) {
    switch (pattern) {
        case BayerPattern::BG: return "BG";
        case BayerPattern::GB: return "GB";
        case BayerPattern::RG: return "RG";
        case BayerPattern::GR: return "GR";
    }
    return "?";
}

std::string_view toString(PixelFormat format) {
    switch (format) {
        case PixelFormat::Mono: return "mono";
        case PixelFormat::Bayer: return "bayer";
        case PixelFormat::Bgr: return "bgr";
    }
    return "?";
}

std::string_view toString(ByteOrder order) { return order == ByteOrder::Little ? "le" : "be"; }

BayerPattern parseBayerPattern(std::string_view text) {
    for (auto p : {BayerPattern::BG, BayerPattern::GB, BayerPattern::RG, BayerPattern::GR})
        if (text == toString(p)) return p;
    throw InvalidArgument("unknown Bayer pattern '" + std::string(text) +
                          "' (expected BG, GB, RG or GR)");
}

ByteOrder hostByteOrder() {
    const std::uint16_t probe = 1;
    unsigned char first = 0;
    std::memcpy(&first, &probe, 1);
    return first == 1 ? ByteOrder::Little : ByteOrder::Big;
}

}  // namespace avatar
