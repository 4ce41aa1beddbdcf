// Allowed: tau uses every layer below it, the renderer included.
#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/analyze/Feature.h>
#include <avatar/render/Renderer.h>
