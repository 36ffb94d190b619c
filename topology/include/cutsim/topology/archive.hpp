#pragma once
// Moved to the base layer: cutsim/base/archive.hpp, in namespace cutsim. This header and its
// names in cutsim::topology stay for code written against earlier releases.
#include "cutsim/base/archive.hpp"

namespace cutsim::topology {
using cutsim::ArchiveReader;
using cutsim::ArchiveWriter;
using cutsim::crc32Of;
using cutsim::fileCrc32;
using cutsim::kArchiveFormat;
}  // namespace cutsim::topology
