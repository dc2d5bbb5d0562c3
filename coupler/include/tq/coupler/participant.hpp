#pragma once
/// @file participant.hpp
/// The coupling API a solver sees, shaped like preCICE's:
///
///     Participant p("solid", config, transport, token);
///     p.setMeshVertices("wall", ids, xyz, triangles);
///     p.initialize();
///     while (p.isCouplingOngoing()) {
///         if (p.requiresWritingCheckpoint()) save();
///         double dt = std::min(solverDt, p.getMaxTimeStepSize());
///         p.readData("wall", "force", f);        // partner's latest values, on my nodes
///         solve(dt);
///         p.writeData("wall", "velocity", v);   // my values, on my nodes
///         p.advance(dt);                        // exchanges when a window is complete
///         if (p.requiresReadingCheckpoint()) restore();
///     }
///     p.finalize();
///
/// Every failure is a typed CouplerError (errors.hpp) whose message names this participant,
/// the partner, the window and iteration, and what was expected. When a call throws, the
/// participant has already told the partner (ABORT) if the link still works, so the partner
/// stops too instead of waiting for its timeout.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tq/coupler/config.hpp"
#include "tq/coupler/divergence.hpp"
#include "tq/coupler/endpoint.hpp"
#include "tq/coupler/maps.hpp"
#include "tq/coupler/messages.hpp"
#include "tq/coupler/scheme.hpp"
#include "tq/coupler/transport.hpp"

namespace tq::coupler {

struct ExchangeStats {
  std::uint64_t exchanges = 0;    ///< DATA messages received
  double secondsInTransport = 0;  ///< inside send/receive, waiting for the partner included
  double secondsWaiting = 0;      ///< of which receives waited for a message's header (partner busy)
  double secondsMapping = 0;      ///< applying interface maps
  std::uint64_t bytesSent = 0, bytesReceived = 0;
};

/// How the parts of a participant in parts add up their sums (the second participant in parts,
/// whose scheme measures, accelerates and decides on the whole interface): sumAll is called by every
/// part with a list of the same length, in the same order of calls, and returns on every part with
/// every part's lists summed element by element (an MPI_Allreduce with MPI_SUM over the solver's
/// ranks). Integer sums: any order of the parts gives the same answer.
class PartGroup {
 public:
  virtual ~PartGroup() = default;
  virtual void sumAll(std::vector<std::int64_t>& values) = 0;
};

class Participant : private ExchangePort {
 public:
  /// `token` is the per-run secret both sides were given by the launcher; the partner must
  /// present the same one.
  Participant(std::string name, CouplingConfig config, TransportOptions transport, std::string token);
  ~Participant() override;
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  /// Declares this side's vertices of interface mesh `mesh` before initialize():
  /// ids (unique), coordinates (3 per node, m), optional surface triangles (3 indices each).
  void setMeshVertices(const std::string& mesh, std::vector<std::int64_t> ids, std::vector<double> coordinates,
                       std::vector<std::int32_t> triangles = {});

  /// A participant split over several processes (the MPI ranks of one solver), each holding its
  /// own nodes of every interface mesh: this process is part `part` of `parts`. Call before
  /// initialize(). Both participants may be in parts; every mesh is mapped with the coincident map
  /// by the first. The first's parts listen over TCP: part 0 publishes the address file, part r > 0
  /// the address file's name with ".part<r>" appended (partAddressFile). Every part of the second
  /// connects to every part of the first (the second in one piece: one part); each connection
  /// carries the nodes the two parts share (none: empty blocks, and the flags). A node of the first
  /// paired by two parts of the second, or by none, and a node of the second in two parts of the
  /// first, or in none, are refused by name in the handshake. The second's scheme measures,
  /// accelerates and decides on the whole interface, each part on its own nodes with its sums
  /// completed through `group` (required for the second in parts; exact sums, so that every part
  /// decides the same and the answer does not depend on the part count), and the first's parts
  /// follow its flags. The divergence monitor runs on the first in one piece, over what it reads,
  /// else on the second, over what it sends. A part may hold no node of a mesh (a rank away from
  /// the interface): it exchanges empty blocks.
  void setPart(int part, int parts, std::shared_ptr<PartGroup> group = nullptr);
  std::uint32_t part() const { return part_; }
  std::uint32_t parts() const { return parts_; }
  /// Parts of the partner (after initialize(); 1 for a partner in one piece).
  std::size_t partnerParts() const { return 1 + partLinks_.size(); }
  /// The nodes of a mesh each of the partner's parts exchanges, in part order (after initialize();
  /// one count, the partner's nodes, for a partner in one piece).
  std::vector<std::size_t> partnerPartNodes(const std::string& mesh) const;

  /// Connects, runs the handshake (refusing a partner with another token, protocol version,
  /// configuration or incompatible mesh), builds the maps, and, on the second participant,
  /// receives the first window's data. Returns the largest allowed step.
  double initialize();

  /// Restart checkpoints (docs/coupler.md "Restart"): the coupling state at a completed window
  /// (the scheme's counters, the acceleration's secant columns, the predictor's history, the
  /// divergence monitor's, the last values exchanged), as bytes. Call right after an advance()
  /// that completed a window (isTimeWindowComplete()), before the next readData/writeData.
  std::vector<unsigned char> saveState() const;
  /// initialize() for a run resumed from saveState() bytes of this side, the partner resumed
  /// from its own of the same window: connects and shakes hands as initialize() does, then
  /// carries on from that window instead of window 0. Throws ConfigError when the bytes do not
  /// fit this configuration.
  double initializeResumed(const std::vector<unsigned char>& state);

  /// Stores this side's values of a field it writes (node-major, my node order).
  void writeData(const std::string& mesh, const std::string& field, const double* values, std::size_t count);
  void writeData(const std::string& mesh, const std::string& field, const std::vector<double>& v) {
    writeData(mesh, field, v.data(), v.size());
  }
  /// Copies the partner's latest values of a field this side reads, mapped to my nodes.
  void readData(const std::string& mesh, const std::string& field, double* values, std::size_t count) const;
  void readData(const std::string& mesh, const std::string& field, std::vector<double>& v) const;

  /// Moves time on by dt; at the end of a window exchanges data and applies the scheme.
  /// Returns the largest allowed next step.
  double advance(double dt);

  bool isCouplingOngoing() const;
  bool isTimeWindowComplete() const;
  bool requiresWritingCheckpoint() const;
  bool requiresReadingCheckpoint() const;
  /// Time left in the current window (s).
  double getMaxTimeStepSize() const;

  /// Clean end: BYE to the partner and wait for its BYE. Before the end of the coupling it
  /// tells the partner that this side stops early (ABORT).
  void finalize();
  /// Tells the partner this side stops on an error (best effort, never throws) and closes.
  void abort(const std::string& reason) noexcept;

  const std::string& name() const { return name_; }
  const std::string& partner() const { return partner_; }
  const CouplingConfig& config() const { return config_; }
  const SchemeState& state() const;
  ExchangeStats stats() const;
  /// Number of partner vertices of a mesh (after initialize).
  std::size_t partnerVertexCount(const std::string& mesh) const;
  /// Simulated time at the start of the current window (s).
  double windowStartTime() const;

 private:
  struct Field;
  struct MeshState;

  // ExchangePort
  void sendData(std::uint64_t window, std::uint32_t iteration, std::uint32_t flags, double residual) override;
  Received receiveData(std::uint64_t window, std::uint32_t iteration) override;
  std::vector<double>& writtenValues() override;
  const std::vector<double>& receivedValues() const override;
  const std::vector<FieldSlice>& writtenSlices() const override { return writtenSlices_; }
  const std::vector<FieldSlice>& receivedSlices() const override { return receivedSlices_; }
  const SumCombiner& sums() const override;

  double connect();
  void checkpoint(StateIo& io);
  Hello makeHello() const;
  /// All the reasons the partner's record is unacceptable ("" if none).
  std::string checkPartner(const Hello& theirs) const;
  void buildMaps(const Hello& theirs);
  /// Handshake, both roles: the partner's record is checked and the maps built; on a mismatch
  /// `reject` tells the partner why and HandshakeError is thrown.
  void acceptPartner(const Hello& theirs, const std::function<void(ReasonCode, const std::string&)>& reject);
  void runAcceptor(Deadline deadline);
  void runConnector(Deadline deadline);
  std::string where() const;
  Field& field(const std::string& mesh, const std::string& name, bool write, const char* caller);
  const Field& field(const std::string& mesh, const std::string& name, bool write, const char* caller) const;
  template <class F>
  auto guarded(const char* what, F&& f) -> decltype(f());

  std::string name_, partner_;
  CouplingConfig config_;
  TransportOptions transport_;
  std::string token_;
  bool amFirst_ = true;
  std::map<std::string, std::unique_ptr<MeshState>> meshes_;
  std::vector<std::unique_ptr<Field>> fields_;
  std::unique_ptr<Endpoint> link_;
  std::unique_ptr<CouplingScheme> scheme_;
  bool initialized_ = false, finalized_ = false;
  double timeInWindow_ = 0.0;
  std::vector<double> written_, received_;  ///< concatenated, for the scheme
  std::vector<FieldSlice> writtenSlices_, receivedSlices_;
  /// First participant: watches the partner's data for a coupling instability.
  std::unique_ptr<DivergenceMonitor> monitor_;
  double secondsMapping_ = 0.0;
  std::uint64_t partnerDataBytes_ = 0;  ///< exact DATA payload size from the partner
  std::uint64_t exchanges_ = 0;
  std::uint32_t part_ = 0, parts_ = 1;  ///< this side's part (setPart)
  std::shared_ptr<PartGroup> group_;    ///< the second in parts: how its parts add their sums
  std::unique_ptr<SumCombiner> sums_;
  /// The data of each link carries only the nodes of partNodes_ (a partner in parts, or the second
  /// in parts); otherwise the one link carries every wire node.
  bool routed_ = false;
  /// A partner in parts: the links to its parts 1.. (link_ is part 0's), the wire indices of the
  /// nodes each link carries, per mesh (ascending), its exact DATA payload size.
  std::vector<std::unique_ptr<Endpoint>> partLinks_;
  std::map<std::string, std::vector<std::vector<std::size_t>>> partNodes_;
  std::vector<std::uint64_t> partDataBytes_;
  std::vector<Endpoint*> links() const;
  void receivePart(std::size_t r, std::uint64_t window, std::uint32_t iteration, const std::string& what,
                   Received& got);
};

/// The address file part `part` of a participant in parts publishes (the name, then ".part<r>" for r > 0).
std::string partAddressFile(const std::string& addressFile, std::uint32_t part);

}  // namespace tq::coupler
