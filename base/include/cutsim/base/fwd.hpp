#pragma once
// Forward declarations of the base layer's classes, for headers that only name them.
namespace cutsim {
class ArchiveWriter;
class ArchiveReader;
class ParameterSource;
}  // namespace cutsim
