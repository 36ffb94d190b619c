#pragma once
// Outputs of a simulation run, all deterministic (no wall-clock figure anywhere: the same scene
// run twice gives byte-identical files):
//  - VTK XML PolyData frames (.vtp, ASCII, shortest round-trip numbers) of the surface at its
//    current positions (point data: velocity, rest_position, slot; cell data: strain = the
//    largest principal Green strain of the triangle in its rest plane), and of the network every
//    force field draws (the first FastTriangularBendingSprings' springs, one line per spring
//    from wing A to wing B, as the "springs" series; every other field's as "network_<label>");
//  - .pvd collections listing the frames with their times (ParaView opens them as animations);
//  - OBJ frames on request;
//  - a CSV row per step (energies, solver figures, counts, grasp reaction forces).
// Frames and collections are written atomically (a temporary file renamed into place), so an
// interrupted run leaves no half-written file under a final name.
#include <filesystem>
#include <fstream>
#include <functional>
#include <iosfwd>
#include <map>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "cutsim/core/scene.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/force_field.hpp"

namespace cutsim::core {

/// The shortest decimal text that reads back to the same double ("0.1", "1e-07", "-0").
std::string formatNumber(double v);

/// Writes `path` through a temporary file in the same folder renamed into place. Throws
/// cutsim::Error naming the path if it cannot be written.
void writeFileAtomically(const std::filesystem::path& path,
                         const std::function<void(std::ostream&)>& write);

/// The surface at the simulation's current positions (live points densely renumbered in
/// ascending slot order, as Topology::toMeshData).
void writeSurfaceVtp(std::ostream& out, const Simulation& sim);
/// The network of `field.draw()` as lines between the live points (numbered as in the surface).
void writeNetworkVtp(std::ostream& out, const Simulation& sim,
                     const forcefields::ForceField& field);
/// The same for segments already drawn.
void writeNetworkVtp(std::ostream& out, const Simulation& sim,
                     std::span<const std::array<PointId, 2>> segments);
/// The border a surface starts with, as segments in rest coordinates, and the answers given so
/// far (an edge's rest endpoints: on it or not), so that each frame costs only its new edges.
struct OriginalBorder {
  std::vector<std::array<Vec3, 2>> segments;
  mutable std::map<std::array<double, 6>, bool> known;
};
OriginalBorder restBorder(const topology::Topology& topo);
/// A border edge of the surface; `lip` when it was opened during the run (a side of a cut, a
/// tear or a removal): its rest points or midpoint are off the `original` border (within a
/// millionth of its extent), which repairs that move points along the border leave alone.
struct BorderEdge {
  PointId a, b;
  bool lip;
};
std::vector<BorderEdge> borderEdges(const topology::Topology& topo, const OriginalBorder& original);
/// The surface's border edges as lines (points numbered as in the surface), with the cell array
/// `lip` (1 opened during the run, 0 the border of the first frame).
void writeBordersVtp(std::ostream& out, const Simulation& sim, const OriginalBorder& original);
/// A ParaView collection: (time, file name relative to the .pvd) per frame.
void writePvd(std::ostream& out, const std::vector<std::pair<double, std::string>>& frames);
/// Line segments in world coordinates (the instruments), two points each.
void writeSegmentsVtp(std::ostream& out, std::span<const std::array<Vec3, 2>> segments);
/// The obstacles' surfaces at time t (planes drawn as squares of side planeSize).
void writeObstaclesVtp(std::ostream& out, const std::vector<forcefields::Obstacle>& obstacles,
                       double t, double planeSize);
/// `run.json` in a run's folder: the scene's name, description, gravity, time step and duration
/// (what the player, cutsim view, shows of the scene, and its "up": against gravity).
void writeRunInfo(const std::filesystem::path& dir, const Scene& scene);
/// OBJ of the live surface at current positions, 17 significant digits.
void writeSurfaceObj(std::ostream& out, const Simulation& sim);

/// What the CSV row of a step needs beyond the simulation itself.
struct StepRecord {
  long step = 0;
  double time = 0.0;
  StepStats stats;
};

/// The writer of a run's output folder. It takes the folder for itself (a second run into the same
/// folder at the same time is refused) and removes what an earlier run wrote there first.
///   surface.pvd, surface_NNNNNN.vtp   springs.pvd, springs_NNNNNN.vtp   frame_NNNNNN.obj
///   network_<label>.pvd, network_<label>_NNNNNN.vtp (every other field that draws)
///   steps.csv (steps.partial.csv for a run stopped before its end): time, kinetic_energy,
///   potential_<label> per force field, gravity_energy,
///     solver_iterations, solver_residual, solver_flags ("ok" or the StepStats flags joined by
///     '+'), newton_iterations, active_springs, points, edges, triangles,
///     <grasp>_fx, <grasp>_fy, <grasp>_fz per grasp of the scene (0 while it is not active);
///     with contact: contact_candidates, contact_active, contact_excluded, contact_clamped,
///     contact_splits, self_normal_force, self_friction_force, and <obstacle>_normal_force,
///     <obstacle>_friction_force per obstacle (sums of the pairs' force magnitudes, N);
///     with settings.energy: energy_stored, the cumulative work_gravity, work_constraints,
///     work_contact, dissipated_damping, energy_removed, energy_balance, energy_drift, and the
///     step's step_work_gravity, ..., step_energy_removed, step_energy_drift (energy.hpp)
///   obstacles.pvd, obstacles_NNNNNN.vtp: the obstacles' surfaces (cell data "obstacle": the
///     obstacle's index), when the scene has obstacles
///   instruments.pvd, instruments_NNNNNN.vtp: the instruments in the world (a scalpel's blade:
///     a line from its tip), from the first frame that has one on
class OutputWriter {
 public:
  /// Creates the folder. fieldLabels, graspNames, contact and obstacleNames fix the CSV's columns.
  OutputWriter(std::filesystem::path dir, OutputSettings settings,
               std::vector<std::string> fieldLabels, std::vector<std::string> graspNames,
               bool contact = false, std::vector<std::string> obstacleNames = {});
  /// The writer of a run resumed from a checkpoint (section "output", saveState): it takes the
  /// folder, keeps the frames written up to the checkpoint, removes the later ones and the
  /// collections, and continues the CSV cut back to its length at the checkpoint (the run's
  /// steps.csv, steps.partial.csv or the CSV being written, whichever still holds those rows,
  /// byte for byte). A folder that does not hold the run's outputs up to the checkpoint (a frame
  /// missing, the last frame or the CSV not the run's): cutsim::Error naming what is wrong.
  OutputWriter(std::filesystem::path dir, OutputSettings settings,
               std::vector<std::string> fieldLabels, std::vector<std::string> graspNames,
               bool contact, std::vector<std::string> obstacleNames, ArchiveReader& in);
  ~OutputWriter();
  OutputWriter(const OutputWriter&) = delete;
  OutputWriter& operator=(const OutputWriter&) = delete;

  /// The CSV row of this step, and a frame if the step is a multiple of `every` or `last`.
  void record(Simulation& sim, const StepRecord& r, bool last);
  /// A frame of this step unless it has one already (the end of a recording that stops between
  /// the `every` steps).
  void frame(Simulation& sim, const StepRecord& r) {
    if (r.step != lastFrameStep_) writeFrame(sim, r);
  }
  /// Flushes and closes the CSV (throws cutsim::Error if it could not be written).
  void finish();
  /// Ends a run stopped before its end (interrupted): the CSV's rows so far flushed and renamed
  /// steps.partial.csv, every collection written whole under its ".partial.pvd" name; nothing
  /// is given the name of a finished run's file. Throws cutsim::Error if the CSV could not be
  /// written.
  void finishPartial();

  /// What draws the instruments at each frame (world segments: a scalpel's blade from its tip);
  /// none: no instruments series.
  void setInstruments(std::function<std::vector<std::array<Vec3, 2>>()> source) {
    instruments_ = std::move(source);
  }

  const std::filesystem::path& dir() const { return dir_; }
  /// The grasps the CSV has reaction-force columns for (fixed when the writer is made).
  const std::vector<std::string>& graspColumns() const { return grasps_; }
  std::size_t framesWritten() const { return surfaceFrames_.size(); }
  /// Files of an earlier run removed from the folder when this writer took it.
  std::size_t replacedFiles() const { return replaced_; }
  /// Whether a file name is one a run writes (frames, collections, the CSV and their temporary
  /// files): what a new run into the same folder removes first.
  static bool isRunOutput(const std::string& name);
  /// The CSV header line (without newline).
  std::string csvHeader() const;
  /// Checkpoints: the section "output": the frames so far, the first frame's border, a checksum
  /// of the last frame's file, and the CSV's length (flushed first) with the checksum of all its
  /// bytes.
  void saveState(ArchiveWriter& out);

 private:
  struct Columns {};
  /// What both constructors start with: the folder and the CSV's columns (nothing done yet).
  OutputWriter(Columns, std::filesystem::path dir, OutputSettings settings,
               std::vector<std::string> fieldLabels, std::vector<std::string> graspNames,
               bool contact, std::vector<std::string> obstacleNames);
  void writeFrame(Simulation& sim, const StepRecord& r);
  void lockFolder(const char* hint);
  // The ends of a run (finish, finishPartial): the CSV flushed and closed, every collection
  // written whole with a suffix (".pvd", ".partial.pvd"), the CSV renamed, the lock released.
  void closeCsv();
  /// Every collection under its name + suffix, listing the frames numbered below `frames`;
  /// `written`, when given, receives each file as soon as it is written (so that a failure part
  /// way knows what to take back).
  void writeCollections(const std::string& suffix, std::size_t frames = ~std::size_t(0),
                        std::vector<std::filesystem::path>* written = nullptr);
  void renameCsv(const std::string& name);
  void releaseFolder();
  /// Whether the partial collections are rewritten after the frames-th frame.
  bool partialDue(std::size_t frames);

  std::filesystem::path dir_;
  OutputSettings settings_;
  std::vector<std::string> labels_, grasps_;
  bool contact_ = false;
  std::vector<std::string> obstacles_;
  std::vector<std::pair<double, std::string>> obstacleFrames_;
  std::vector<std::pair<double, std::string>> borderFrames_;
  OriginalBorder originalBorder_;  // the border of the first frame
  std::ofstream csv_;
  std::filesystem::path csvTemp_;
  std::vector<std::pair<double, std::string>> surfaceFrames_;
  std::map<std::string, std::vector<std::pair<double, std::string>>> networkFrames_;  // by series
  std::function<std::vector<std::array<Vec3, 2>>()> instruments_;
  long lastFrameStep_ = -1;
  std::size_t nextPartial_ = 0;
  std::size_t partialFrames_ = 0;  // frames the partial collections listed when last written
  std::uint32_t csvCrc_ = 0;       // CRC-32 of the CSV's bytes so far (checkpoints)
  void writeCsv(const std::string& text);
  int lockFd_ = -1;  // the folder's lock (flock on DIR/.cutsim.lock), held while the writer lives
  std::size_t replaced_ = 0;
};

/// `--dump-final`: final_rest.obj and final.obj (the live points densely renumbered, rest and
/// current positions, the same triangles, 17 significant digits) and final_forces.json (the force
/// of `bending` at the current positions, zero velocity, per vertex of the OBJs, in the form of
/// `cutsim eval`'s output: energy, active_springs, forces, counters and parameters echoed).
void dumpFinal(const std::filesystem::path& dir, const Simulation& sim,
               const forcefields::FastTriangularBendingSprings* bending);

}  // namespace cutsim::core
