// Keeps the support library non-empty; helpers live in headers and their own .cpp files.
#include "test_paths.h"
