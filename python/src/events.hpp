#pragma once
// Topology events as Python objects: the bridge that forwards the topology's events to the
// Python callbacks, and a plain C++ log of them that the tests compare with (events.cpp).
#include "bindings.hpp"

namespace cutsim::python {

struct Event {
  explicit Event(std::string k) : kind(std::move(k)) {}
  std::string kind;  // "points_created", ...
  py::object ids = py::none(), vertices = py::none(), edges = py::none();
  py::object offsets = py::none(), ancestors = py::none(), weights = py::none();
  py::object oldToNew = py::none();
  long newSize = 0;
  std::string operation;
  py::object summary = py::none();
};

/// Forwards every topology event to the Python callbacks (with the GIL), and stamps the layout.
class EventBridge final : public topology::TopologyObserver {
 public:
  explicit EventBridge(Simulation& s) : sim_(s) {}
  void onTrianglesDestroyed(const topology::Topology&,
                            const topology::TrianglesDestroyed& e) override;
  void onEdgesDestroyed(const topology::Topology&, const topology::EdgesDestroyed& e) override;
  void onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed& e) override;
  void onPointsCreated(const topology::Topology&, const topology::PointsCreated& e) override;
  void onEdgesCreated(const topology::Topology&, const topology::EdgesCreated& e) override;
  void onTrianglesCreated(const topology::Topology&, const topology::TrianglesCreated& e) override;
  void onPointsRenumbered(const topology::Topology&, const topology::Renumbering& r) override;
  void onEdgesRenumbered(const topology::Topology&, const topology::Renumbering& r) override;
  void onTrianglesRenumbered(const topology::Topology&, const topology::Renumbering& r) override;
  void onTransactionEnd(const topology::Topology&, const topology::TransactionSummary& s) override;
  std::string observerName() const override { return "Python event callbacks"; }

  bool wanted() const;

 private:
  void renumbered(const char* kind, const topology::Renumbering& r);
  template <class Make>
  void emit(Make&& make);

  Simulation& sim_;
};

/// A plain C++ observer that writes each event as one line of text, independently of the Python
/// events: the tests compare the events Python callbacks receive with it (Simulation._cpp_events).
class EventLog final : public topology::TopologyObserver {
 public:
  std::vector<std::string> lines;
  void onTrianglesDestroyed(const topology::Topology&,
                            const topology::TrianglesDestroyed& e) override {
    lines.push_back("triangles_destroyed:" + join(e.triangles) + "|" + rows(e.vertices));
  }
  void onEdgesDestroyed(const topology::Topology&, const topology::EdgesDestroyed& e) override {
    lines.push_back("edges_destroyed:" + join(e.edges) + "|" + rows(e.vertices));
  }
  void onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed& e) override {
    lines.push_back("points_destroyed:" + join(e.points));
  }
  void onPointsCreated(const topology::Topology&, const topology::PointsCreated& e) override {
    std::string w;
    for (std::size_t i = 0; i < e.weights.size(); ++i) {
      char buf[40];
      std::snprintf(buf, sizeof buf, "%.17g", e.weights[i]);
      w += (i ? "," : "") + std::string(buf);
    }
    lines.push_back("points_created:" + join(e.points) + "|" + join(e.offsets) + "|" +
                    join(e.ancestors) + "|" + w);
  }
  void onEdgesCreated(const topology::Topology&, const topology::EdgesCreated& e) override {
    lines.push_back("edges_created:" + join(e.edges) + "|" + rows(e.vertices));
  }
  void onTrianglesCreated(const topology::Topology&, const topology::TrianglesCreated& e) override {
    lines.push_back("triangles_created:" + join(e.triangles) + "|" + rows(e.vertices) + "|" +
                    rows(e.edges));
  }
  void onPointsRenumbered(const topology::Topology&, const topology::Renumbering& r) override {
    renumbered("points", r);
  }
  void onEdgesRenumbered(const topology::Topology&, const topology::Renumbering& r) override {
    renumbered("edges", r);
  }
  void onTrianglesRenumbered(const topology::Topology&, const topology::Renumbering& r) override {
    renumbered("triangles", r);
  }
  void onTransactionEnd(const topology::Topology&, const topology::TransactionSummary& s) override {
    std::ostringstream o;
    o << "transaction_end:" << s.operation << "|" << s.pointsCreated << "," << s.pointsDestroyed
      << "," << s.edgesCreated << "," << s.edgesDestroyed << "," << s.trianglesCreated << ","
      << s.trianglesDestroyed << "," << (s.renumbered ? 1 : 0);
    lines.push_back(o.str());
  }
  std::string observerName() const override { return "event log"; }

 private:
  static std::string number(Index v) {
    return v == topology::kInvalidIndex ? "-1" : std::to_string(v);
  }
  template <class Ids>
  static std::string join(const Ids& ids) {
    std::string out;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      if (i) out += ',';
      out += number(Index(ids[i]));
    }
    return out;
  }
  template <class Rows>
  static std::string rows(const Rows& r) {
    std::string out;
    for (std::size_t i = 0; i < r.size(); ++i) {
      if (i) out += ';';
      out += join(r[i]);
    }
    return out;
  }
  void renumbered(const char* kind, const topology::Renumbering& r) {
    lines.push_back(std::string(kind) + "_renumbered:" + std::to_string(r.newSize) + "|" +
                    join(r.oldToNew));
  }
};

}  // namespace cutsim::python
