#include <avatar/acquire/AcquireStereoImagePair.h>

#include <avatar/config/ConfigXml.h>

namespace avatar {

std::optional<AvatarConfig> AcquiredPair::recordedConfig() const {
    if (!recordedConfigXml) return std::nullopt;
    return readConfigString(*recordedConfigXml, recordedConfigSource);
}

AcquireStereoImagePair::AcquireStereoImagePair(std::uint32_t groupSize) : groupSize_(groupSize) {
    if (groupSize < 1 || groupSize > 99999)
        throw InvalidArgument("acquisition group size " + std::to_string(groupSize) + " outside 1..99999");
}

AcquiredPair AcquireStereoImagePair::acquire() {
    AcquiredPair acquired = grab();
    if (acquired.pair.empty()) throw AcquisitionError(name() + ": backend returned no images");
    if (acquired.recordedIteration) return acquired;  // replay keeps its recorded numbers
    AcquisitionId id = acquired.pair.id();
    id.group = group_;
    id.member = member_;
    acquired.pair.setId(id);
    if (++member_ >= groupSize_) {
        member_ = 0;
        ++group_;
    }
    return acquired;
}

std::array<CameraFeatureReadback, 2> AcquireStereoImagePair::readFeatures() const {
    throw NotAvailable("the " + name() + " backend has no cameras whose features could be read back");
}

void AcquireStereoImagePair::applyConfig(const AvatarConfig& config) {
    configure(config);  // throws and leaves everything as it was if it cannot
    if (member_ != 0) {
        ++group_;
        member_ = 0;
    }
}

}  // namespace avatar
