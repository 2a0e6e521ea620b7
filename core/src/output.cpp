#include "core/output.hpp"
