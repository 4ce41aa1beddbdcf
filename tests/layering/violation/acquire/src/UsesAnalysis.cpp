// Planted violation: the acquisition layer uses the analysis.
#include <avatar/analyze/Feature.h>
#include <avatar/common/Error.h>
