// A header of the acquisition layer, reached from below by a relative path.
#pragma once
