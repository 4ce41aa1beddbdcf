// Planted violation: a quoted include that leaves the common folder.
#include "../../acquire/src/Helper.h"
