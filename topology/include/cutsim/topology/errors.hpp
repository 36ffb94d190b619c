#pragma once
// Moved to the base layer: cutsim/base/errors.hpp (the errors were always in namespace cutsim).
// This header stays for code written against earlier releases; include the new one.
#include "cutsim/base/errors.hpp"
