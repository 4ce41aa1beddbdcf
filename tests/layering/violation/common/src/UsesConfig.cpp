// Planted violation: common knows config.
#include <avatar/config/AvatarConfig.h>
