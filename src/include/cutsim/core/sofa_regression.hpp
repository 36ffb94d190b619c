#pragma once
// SOFA's regression tests: the list of scenes (".regression-tests": one line per scene, "SCENE
// STEPS EPSILON MECA_IN_MAPPING DUMP_ONLY_LAST_STEP"), the reference files (gzipped text, one frame
// per written time: "T= t", "  X= x0 y0 z0 ...", "  V= ...", 6 significant digits) and the
// comparison of a run with a reference (docs/sofa.md):
//
// - SOFA's legacy metric (its C++ test): per compared frame, the mean absolute difference over
//   every scalar of X (the run's values printed to 6 digits, as SOFA compares them), divided again
//   by the number of points, plus the same for V; summed over the frames; the test fails above
//   the list's epsilon;
// - the newer, positions-only metric (its Python runner): the Euclidean norm of the difference of
//   X divided by 3N, summed over the frames;
// - the largest distance between a point's position and the reference's, with its point and time,
//   and the largest difference of a coordinate printed as the reference prints it.
//
// A run writes its frames at the start of a step (SOFA's WriteState on AnimateBeginEvent): at
// T = 0 and, with "dump only the last step", at T = dt (steps - 1): the state after steps - 1
// steps; else at every step from 0 to steps - 1.
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace cutsim::core {

struct RegressionEntry {
  std::filesystem::path scene;  ///< as written in the list (relative to the list's folder)
  long steps = 100;
  double epsilon = 1e-4;
  bool mechanicalInMapping = false;
  bool onlyLastStep = false;
  std::size_t line = 0;
};

/// Reads a list ('#' comments and blank lines skipped; the fields after the scene are optional,
/// SOFA's defaults 100 1e-4 0 0). Throws InvalidInput "LIST:LINE: message".
std::vector<RegressionEntry> readRegressionList(const std::filesystem::path& list);

struct StateFrame {
  double time = 0.0;
  std::vector<double> x, v;  ///< 3 per point
};

/// SOFA's text of the frames (6 significant digits, as C++ streams print by default).
std::string formatReference(const std::vector<StateFrame>& frames);
/// Writes the frames gzipped (zlib), atomically (a temporary file renamed).
void writeReference(const std::filesystem::path& file, const std::vector<StateFrame>& frames);
/// Reads a gzipped (or plain) reference. Throws InvalidInput "FILE:LINE: message".
std::vector<StateFrame> readReference(const std::filesystem::path& file);

/// The reference file SOFA names for the list entry's scene and its i-th mechanical object.
std::filesystem::path referencePath(const std::filesystem::path& refsDir,
                                    const RegressionEntry& entry, std::size_t index,
                                    const std::string& mechanicalObject);

struct RegressionComparison {
  double legacy = 0.0;           ///< SOFA's C++ metric (X and V)
  double positions = 0.0;        ///< SOFA's Python metric (X only)
  double largestDistance = 0.0;  ///< max over frames and points of |x - x_ref|
  /// max over frames and coordinates of |x_ref - x| with x printed to the reference's 6 digits
  /// (0: the run gives the reference's numbers to every printed digit)
  double largestPrintedDifference = 0.0;
  std::size_t worstPoint = 0;
  double worstTime = 0.0;
  std::size_t frames = 0;  ///< frames compared
};

/// Compares a run's frames with the reference's, frame by frame at the reference's times (a
/// reference time the run did not write, or different point counts: InvalidInput naming `what`).
RegressionComparison compareWithReference(const std::vector<StateFrame>& reference,
                                          const std::vector<StateFrame>& run, double dt,
                                          const std::string& what);

/// Runs a SOFA scene (.scn) for the entry's steps and returns the frames SOFA's WriteState would
/// write. `mechanicalObject` gets the scene's MechanicalObject name; `notes` the reader's notes;
/// `flaggedSteps` the steps whose solves missed their tolerance.
std::vector<StateFrame> runForRegression(const std::filesystem::path& scene,
                                         const RegressionEntry& entry,
                                         std::string& mechanicalObject,
                                         std::vector<std::string>& notes, long& flaggedSteps);

}  // namespace cutsim::core
