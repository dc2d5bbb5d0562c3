// A participant in parts (Participant::setPart): the first participant split over several
// processes, each with its own nodes and its own connection, against the same coupling in one
// piece. The added-mass oscillators of test_participant.cpp, one per node with its own stiffness,
// implicit with Aitken and IQN-ILS: the partner measures, accelerates and decides on the whole
// interface, so the pass count of every window and every value hang on every node's.
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <map>
#include <mutex>
#include <numeric>

#include "coupler_test_util.hpp"

using namespace tqtest;

namespace {

/// What each side saved at a window's end (Participant::saveState) with its own state there: the
/// solid's parts, each its own, and the fluid's.
struct PartsSaved {
  int window = 0;
  std::vector<std::vector<unsigned char>> part;
  std::vector<std::vector<double>> x, v;
  std::vector<std::vector<unsigned char>> fluid;  ///< each fluid part's
  std::vector<std::vector<double>> vOld;
};

/// The fluid's parts in threads of one process: sumAll as an MPI_Allreduce (MPI_SUM), every part's
/// lists added element by element; a part that waits 10 s for the others throws.
class ThreadGroup final : public PartGroup {
 public:
  explicit ThreadGroup(int parts) : parts_(parts) {}
  void sumAll(std::vector<std::int64_t>& v) override {
    std::unique_lock<std::mutex> lock(mutex_);
    if (arrived_ == 0)
      sum_ = v;
    else
      for (std::size_t i = 0; i < v.size() && i < sum_.size(); ++i) sum_[i] += v[i];
    ++calls_;
    const std::uint64_t round = round_;
    if (++arrived_ == parts_) {
      result_ = sum_, arrived_ = 0, ++round_;
      done_.notify_all();
    } else if (!done_.wait_for(lock, std::chrono::seconds(10), [&] { return round_ != round; })) {
      throw TimeoutError("a fluid part waited 10 s for the other parts' sums");
    }
    v = result_;
  }
  std::uint64_t calls() const { return calls_; }

 private:
  int parts_, arrived_ = 0;
  std::uint64_t round_ = 0, calls_ = 0;
  std::vector<std::int64_t> sum_, result_;
  std::mutex mutex_;
  std::condition_variable done_;
};

/// The oscillators' run: x of every node at every window's end ([window][node], nodes in the
/// ring's order), the passes of every window, and what each part held.
struct PartsRun {
  std::vector<std::vector<double>> x;
  std::vector<int> passes;
  std::vector<std::size_t> partNodes;      ///< nodes each part exchanged
  std::vector<std::size_t> fluidNodes;     ///< nodes each fluid part exchanged
  std::vector<std::size_t> partnerParts;   ///< each fluid part's count of the solid's parts
  std::vector<std::size_t> solidSees;      ///< each solid part's count of the fluid's parts
  std::vector<std::exception_ptr> errors;  ///< the parts', then the fluid parts'
  double seconds = 0;                      ///< the coupled run's wall time
  PartsSaved saved;                        ///< at the end of window `saveAt`
};

/// The node's part: interleaved around the ring (each part holds several separate arcs).
int partOf(int node, int parts) { return (node / 3 + node % 2) % parts; }
/// A fluid node's part (k in the fluid's order): contiguous arcs, cut elsewhere than the solid's.
int fluidPartOf(int k, int parts, int n) { return ((k + 5) % n) * parts / n; }

/// The solid in `parts` parts (threads) and the fluid in `fluidParts` (threads; 1: one piece, no
/// group), partOf() and fluidPartOf() the part of each node; `also` one node a second solid part
/// claims too (−1: none), `fluidAlso` one fluid node (fluid order) a second fluid part claims too;
/// `emptyLast`: the last solid part holds no node; `saveAt`: every side saves its state at that
/// window's end and runs on (0: none); `resume`: every side starts from those states
/// (initializeResumed) instead; `emptyFluidLast`: the last fluid part holds no node; `scheme`: the
/// coupling scheme.
PartsRun coupleInParts(int parts, AccelerationKind acc, int windows, int also = -1, bool emptyLast = false,
                       int saveAt = 0, const PartsSaved* resume = nullptr, int fluidParts = 1, int fluidAlso = -1,
                       bool emptyFluidLast = false, SchemeKind scheme = SchemeKind::Implicit) {
  const int used = emptyLast ? parts - 1 : parts;  // the parts that hold nodes
  const auto dir = freshDir();
  auto c = ringConfig(scheme, std::uint64_t(windows));
  c.acceleration = acc;
  c.tolerance = 1e-9;
  c.maxIterations = 40;
  scenario::Ring r;
  r.nTheta = 12;
  r.nLayers = 2;
  const int n = r.nodes();
  const double dt = c.windowSize, m = 1.0, ma = 4.0;
  PartsRun out;
  out.x.assign(std::size_t(windows), std::vector<double>(std::size_t(n), 0.0));
  out.passes.assign(std::size_t(windows), 0);
  out.partNodes.assign(std::size_t(parts), 0);
  out.fluidNodes.assign(std::size_t(fluidParts), 0);
  out.partnerParts.assign(std::size_t(fluidParts), 0);
  out.solidSees.assign(std::size_t(parts), 0);
  out.errors.assign(std::size_t(parts + fluidParts), nullptr);
  out.saved.fluid.resize(std::size_t(fluidParts)), out.saved.vOld.resize(std::size_t(fluidParts));
  out.saved.window = saveAt;
  out.saved.part.resize(std::size_t(parts)), out.saved.x.resize(std::size_t(parts)),
      out.saved.v.resize(std::size_t(parts));
  const auto ids = r.solidIds();
  const auto xyz = r.solidCoordinates();
  auto solidPart = [&](int part) {
    std::vector<int> mine;  // the ring's node indices this part holds, ascending
    for (int k = 0; k < n; ++k)
      if (partOf(k, used) == part || (k == also && part == (partOf(k, used) + 1) % used)) mine.push_back(k);
    std::vector<std::int64_t> pid;
    std::vector<double> pxyz;
    for (int k : mine) {
      pid.push_back(ids[std::size_t(k)]);
      pxyz.insert(pxyz.end(), xyz.begin() + 3 * k, xyz.begin() + 3 * k + 3);
    }
    Participant p("solid", c, tcp(dir), "tok-parts");
    if (parts > 1) p.setPart(part, parts);
    p.setMeshVertices("wall", pid, pxyz);
    const std::size_t q = mine.size(), me = std::size_t(part);
    std::vector<double> x(q), v(q, 0.0), xs, vs, f, vel(3 * q, 0.0);
    for (std::size_t i = 0; i < q; ++i) x[i] = 0.01 * std::cos(r.theta(mine[i])) + 0.002 * double(mine[i] / r.nTheta);
    int window = 0, inWindow = 0;
    if (resume) {
      p.initializeResumed(resume->part[me]);
      x = resume->x[me], v = resume->v[me], window = resume->window;
    } else {
      p.initialize();
    }
    out.partNodes[me] = mine.size();
    out.solidSees[me] = p.partnerParts();
    while (p.isCouplingOngoing()) {
      if (p.requiresWritingCheckpoint()) xs = x, vs = v;
      p.readData("wall", "force", f);
      ++inWindow;
      for (std::size_t i = 0; i < q; ++i) {
        const double k = 4 * M_PI * M_PI * (16.0 + double(mine[i] % 7)) * (m + ma);  // 4–5 Hz coupled
        v[i] += dt * (-k * x[i] + f[3 * i]) / m;
        x[i] += dt * v[i];
        vel[3 * i] = v[i];
      }
      p.writeData("wall", "velocity", vel);
      p.advance(dt);
      if (p.requiresReadingCheckpoint()) {
        x = xs, v = vs;
      } else {
        for (std::size_t i = 0; i < q; ++i) out.x[std::size_t(window)][std::size_t(mine[i])] = x[i];
        if (part == 0) out.passes[std::size_t(window)] = inWindow;
        ++window, inWindow = 0;
        if (window == saveAt) out.saved.part[me] = p.saveState(), out.saved.x[me] = x, out.saved.v[me] = v;
      }
    }
    p.finalize();
  };
  auto group = std::make_shared<ThreadGroup>(fluidParts);
  auto fluid = [&](int part) {
    const auto fids = r.fluidIds();
    const auto fxyz = r.fluidCoordinates();
    std::vector<std::int64_t> pid;
    std::vector<double> pxyz;
    const int fluidUsed = emptyFluidLast ? fluidParts - 1 : fluidParts;
    for (int k = 0; k < n; ++k)
      if (fluidPartOf(k, fluidUsed, n) == part ||
          (k == fluidAlso && part == (fluidPartOf(k, fluidUsed, n) + 1) % fluidUsed)) {
        pid.push_back(fids[std::size_t(k)]);
        pxyz.insert(pxyz.end(), fxyz.begin() + 3 * k, fxyz.begin() + 3 * k + 3);
      }
    Participant p("fluid", c, tcp(dir), "tok-parts");
    const std::size_t me = std::size_t(part), q = pid.size();
    if (fluidParts > 1) {
      p.setPart(part, fluidParts, group);
      p.setMeshVertices("wall", pid, pxyz);
    } else {
      setRing(p, r, false);
    }
    std::vector<double> vOld(3 * q, 0.0), vs, vNew, f(3 * q);
    if (resume) {
      p.initializeResumed(resume->fluid[me]);
      vOld = resume->vOld[me];
    } else {
      p.initialize();
    }
    out.fluidNodes[me] = q;
    out.partnerParts[me] = p.partnerParts();
    while (p.isCouplingOngoing()) {
      if (p.requiresWritingCheckpoint()) vs = vOld;
      p.readData("wall", "velocity", vNew);
      for (std::size_t i = 0; i < f.size(); ++i) f[i] = -ma * (vNew[i] - vOld[i]) / dt;
      p.writeData("wall", "force", f);
      p.advance(dt);
      vOld = p.requiresReadingCheckpoint() ? vs : vNew;
      if (p.isTimeWindowComplete() && int(p.state().window) == saveAt)
        out.saved.fluid[me] = p.saveState(), out.saved.vOld[me] = vOld;
    }
    p.finalize();
  };
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::thread> threads;
  for (int part = 0; part < parts; ++part)
    threads.emplace_back([&, part] {
      try {
        solidPart(part);
      } catch (...) {
        out.errors[std::size_t(part)] = std::current_exception();
      }
    });
  for (int part = 0; part < fluidParts; ++part)
    threads.emplace_back([&, part] {
      try {
        fluid(part);
      } catch (...) {
        out.errors[std::size_t(parts + part)] = std::current_exception();
      }
    });
  for (auto& t : threads) t.join();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace

TEST(Parts, TheSolidInPartsCouplesBitwiseAsInOnePiece) {
  for (auto acc : {AccelerationKind::Aitken, AccelerationKind::IqnIls}) {
    const PartsRun one = coupleInParts(1, acc, 40);
    for (const auto& e : one.errors) rethrowIf(e);
    int total = std::accumulate(one.passes.begin(), one.passes.end(), 0);
    EXPECT_GT(total, 40 * 3) << accelerationName(acc) << ": the iteration must be a real one";
    for (int parts : {2, 3, 5, 4}) {
      const bool emptyLast = parts == 4;  // 3 parts with nodes and one (a rank away from the wall) without
      const PartsRun split = coupleInParts(parts, acc, 40, -1, emptyLast);
      for (const auto& e : split.errors) rethrowIf(e);
      // no part holds the whole interface; the parts' nodes add up to it, each node once
      std::size_t sum = 0;
      for (std::size_t q : split.partNodes) {
        EXPECT_LT(q, one.partNodes[0]);
        sum += q;
      }
      EXPECT_EQ(split.partNodes.back() == 0, emptyLast);
      EXPECT_EQ(sum, one.partNodes[0]);
      EXPECT_EQ(split.partnerParts, std::vector<std::size_t>{std::size_t(parts)});
      EXPECT_EQ(split.passes, one.passes) << accelerationName(acc) << ", " << parts << " parts";
      for (std::size_t w = 0; w < one.x.size(); ++w)
        for (std::size_t k = 0; k < one.x[w].size(); ++k)
          ASSERT_EQ(split.x[w][k], one.x[w][k])
              << accelerationName(acc) << ", " << parts << " parts, window " << w << ", node " << k;
    }
    std::cout << "[ info ] " << accelerationName(acc) << ": " << double(total) / 40.0
              << " passes per window, equal bitwise on 2, 3 and 5 parts and on 4 with one empty\n";
  }
}

TEST(Parts, ANodeInTwoPartsIsRefusedOnEverySide) {
  const PartsRun run = coupleInParts(3, AccelerationKind::Aitken, 4, /*also=*/7);
  const std::string fluid = messageOf<HandshakeError>(run.errors.back());
  EXPECT_TRUE(contains(fluid, "node 1007 is in part")) << fluid;
  EXPECT_TRUE(contains(fluid, "each node belongs to one part")) << fluid;
  for (int part = 0; part < 3; ++part) EXPECT_TRUE(run.errors[std::size_t(part)]) << "part " << part;
}

TEST(Parts, APartThatCannotBeOneIsRefusedBeforeItListens) {
  const auto dir = freshDir();
  auto c = ringConfig(SchemeKind::Implicit, 4);
  scenario::Ring r;
  Participant second("fluid", c, tcp(dir), "tok");
  second.setPart(1, 2);  // no PartGroup: its parts could not decide together
  setRing(second, r, false);
  try {
    second.initialize();
    FAIL() << "the second participant in parts without a group was accepted";
  } catch (const ConfigError& e) {
    EXPECT_TRUE(contains(e.what(), "in 2 parts: it needs a PartGroup")) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "wall.addr.part1"));
  Participant p("solid", c, tcp(dir), "tok");
  EXPECT_THROW(p.setPart(2, 2), ConfigError);
}

// A restart of the coupling in parts: every part and the fluid save their state at the end of window
// 17 (Participant::saveState, each part its own bytes) and run on; a new run started from those
// states (initializeResumed: the fluid connects to every part again and checks them) must give every
// node's motion at every later window's end and every window's passes bitwise equal to the run never
// stopped, which is itself bitwise the one-piece run (above).
TEST(Parts, TheSolidInPartsResumesFromSavedStatesBitwise) {
  for (auto acc : {AccelerationKind::Aitken, AccelerationKind::IqnIls})
    for (int parts : {2, 3}) {
      const int windows = 30, at = 17;
      const PartsRun whole = coupleInParts(parts, acc, windows, -1, false, at);
      for (const auto& e : whole.errors) rethrowIf(e);
      for (const auto& b : whole.saved.part) ASSERT_FALSE(b.empty());
      ASSERT_FALSE(whole.saved.fluid[0].empty());
      const PartsRun resumed = coupleInParts(parts, acc, windows, -1, false, 0, &whole.saved);
      for (const auto& e : resumed.errors) rethrowIf(e);
      EXPECT_EQ(resumed.partnerParts, std::vector<std::size_t>{std::size_t(parts)});
      for (std::size_t w = std::size_t(at); w < std::size_t(windows); ++w) {
        EXPECT_EQ(resumed.passes[w], whole.passes[w])
            << accelerationName(acc) << ", " << parts << " parts, window " << w;
        for (std::size_t k = 0; k < whole.x[w].size(); ++k)
          ASSERT_EQ(resumed.x[w][k], whole.x[w][k])
              << accelerationName(acc) << ", " << parts << " parts, window " << w << ", node " << k;
      }
    }
}

// Both participants in parts: the fluid's parts (threads with a ThreadGroup) hold contiguous arcs
// cut elsewhere than the solid's interleaved ones, so most solid parts share nodes with several
// fluid parts and each link carries a few nodes or none. The fluid's scheme measures, accelerates
// (Aitken; IQN-ILS with its Gram matrix) and decides on the whole interface through exact sums
// combined over its parts: every node's motion at every window's end and every window's passes
// are bitwise those of both in one piece, for the fluid in 2 and 3 parts against the solid in 1, 2
// and 3.
TEST(Parts, BothInPartsCoupleBitwiseAsBothInOnePiece) {
  for (auto acc : {AccelerationKind::Aitken, AccelerationKind::IqnIls}) {
    const PartsRun one = coupleInParts(1, acc, 40);
    for (const auto& e : one.errors) rethrowIf(e);
    const int total = std::accumulate(one.passes.begin(), one.passes.end(), 0);
    EXPECT_GT(total, 40 * 3) << accelerationName(acc) << ": the iteration must be a real one";
    const std::size_t n = one.partNodes[0];
    for (int fluidParts : {2, 3})
      for (int parts : {1, 2, 3}) {
        const PartsRun split = coupleInParts(parts, acc, 40, -1, false, 0, nullptr, fluidParts);
        for (const auto& e : split.errors) rethrowIf(e);
        std::size_t sum = 0;
        for (std::size_t q : split.fluidNodes) {
          EXPECT_LT(q, n);
          sum += q;
        }
        EXPECT_EQ(sum, n);  // each fluid node in one part
        EXPECT_EQ(split.partnerParts, std::vector<std::size_t>(std::size_t(fluidParts), std::size_t(parts)));
        EXPECT_EQ(split.solidSees, std::vector<std::size_t>(std::size_t(parts), std::size_t(fluidParts)));
        EXPECT_EQ(split.passes, one.passes) << accelerationName(acc) << ", fluid " << fluidParts << ", solid " << parts;
        for (std::size_t w = 0; w < one.x.size(); ++w)
          for (std::size_t k = 0; k < one.x[w].size(); ++k)
            ASSERT_EQ(split.x[w][k], one.x[w][k]) << accelerationName(acc) << ", fluid " << fluidParts
                                                  << " parts, solid " << parts << ", window " << w << ", node " << k;
        std::cout << "[ info ] " << accelerationName(acc) << ", fluid " << fluidParts << " x solid " << parts
                  << ": fluid part nodes";
        for (std::size_t q : split.fluidNodes) std::cout << " " << q;
        std::cout << ", " << split.seconds << " s against " << one.seconds << " s in one piece, bitwise\n";
      }
    std::cout << "[ info ] " << accelerationName(acc) << ": " << double(total) / 40.0 << " passes per window\n";
  }
}

// A fluid node held by two fluid parts: the solid part holding the node it pairs with refuses the
// fluid by name (the node, both parts), and every part of both sides stops in the handshake.
TEST(Parts, AFluidNodeInTwoPartsIsRefusedByName) {
  const int n = 24, k = 7;  // fluid node 7 is solid node 16: id 500016 on the fluid, 1016 on the solid
  const PartsRun run = coupleInParts(2, AccelerationKind::Aitken, 4, -1, false, 0, nullptr, 3, k);
  const int a = fluidPartOf(k, 3, n), b = (a + 1) % 3;
  const std::string named = "node 500016 is in part " + std::to_string(std::min(a, b)) +
                            " (as node 500016) and in part " + std::to_string(std::max(a, b)) +
                            " (each node belongs to one part; node 1016 of 'solid')";
  bool solidSaid = false;
  for (int part = 0; part < 2; ++part) {
    ASSERT_TRUE(run.errors[std::size_t(part)]) << "solid part " << part;
    solidSaid |= contains(messageOf<std::exception>(run.errors[std::size_t(part)]), named);
  }
  EXPECT_TRUE(solidSaid) << messageOf<std::exception>(run.errors[0]) << "\n"
                         << messageOf<std::exception>(run.errors[1]);
  for (int part = 0; part < 3; ++part) {
    const std::string fluid = messageOf<HandshakeError>(run.errors[std::size_t(2 + part)]);
    EXPECT_TRUE(contains(fluid, named)) << "fluid part " << part << ": " << fluid;
  }
}

// Both in parts resume from their saved states bitwise (each fluid part its own bytes).
TEST(Parts, BothInPartsResumeFromSavedStatesBitwise) {
  for (auto acc : {AccelerationKind::Aitken, AccelerationKind::IqnIls}) {
    const int windows = 30, at = 17;
    const PartsRun whole = coupleInParts(2, acc, windows, -1, false, at, nullptr, 3);
    for (const auto& e : whole.errors) rethrowIf(e);
    const PartsRun resumed = coupleInParts(2, acc, windows, -1, false, 0, &whole.saved, 3);
    for (const auto& e : resumed.errors) rethrowIf(e);
    for (std::size_t w = std::size_t(at); w < std::size_t(windows); ++w) {
      EXPECT_EQ(resumed.passes[w], whole.passes[w]) << accelerationName(acc) << ", window " << w;
      for (std::size_t k = 0; k < whole.x[w].size(); ++k)
        ASSERT_EQ(resumed.x[w][k], whole.x[w][k]) << accelerationName(acc) << ", window " << w << ", node " << k;
    }
  }
}

// A fluid part that holds no node (a water rank away from the wall) takes part in every sum and
// decision with empty blocks: the same answer bitwise; and an unstable coupling (explicit, added
// mass 4 x the mass) is stopped by the divergence monitor on the fluid's parts, from their combined
// sums, at the window where the solid in one piece stops it, on every fluid part with the same words.
TEST(Parts, AnEmptyFluidPartAndTheDivergenceMonitorOnFluidPartsDecideAsOnePiece) {
  const PartsRun one = coupleInParts(1, AccelerationKind::IqnIls, 40);
  for (const auto& e : one.errors) rethrowIf(e);
  const PartsRun split = coupleInParts(2, AccelerationKind::IqnIls, 40, -1, false, 0, nullptr, 4, -1, true);
  for (const auto& e : split.errors) rethrowIf(e);
  EXPECT_EQ(split.fluidNodes.back(), 0u);
  EXPECT_EQ(split.passes, one.passes);
  for (std::size_t w = 0; w < one.x.size(); ++w)
    for (std::size_t k = 0; k < one.x[w].size(); ++k) ASSERT_EQ(split.x[w][k], one.x[w][k]) << w << ", " << k;

  const PartsRun whole =
      coupleInParts(1, AccelerationKind::None, 200, -1, false, 0, nullptr, 1, -1, false, SchemeKind::Explicit);
  const std::string stop = messageOf<DivergenceError>(whole.errors[0]);
  const auto at = stop.find("the coupling is unstable at");
  ASSERT_NE(at, std::string::npos) << stop;
  const std::string said = stop.substr(at);  // "the coupling is unstable at t = ... (window N): ..."
  const PartsRun parts =
      coupleInParts(2, AccelerationKind::None, 200, -1, false, 0, nullptr, 3, -1, false, SchemeKind::Explicit);
  for (int q = 0; q < 3; ++q) {
    const std::string fluid = messageOf<DivergenceError>(parts.errors[std::size_t(2 + q)]);
    EXPECT_TRUE(contains(fluid, "participant 'fluid': " + said)) << "fluid part " << q << ": " << fluid << "\n" << stop;
  }
  for (int r = 0; r < 2; ++r) EXPECT_TRUE(parts.errors[std::size_t(r)]) << "solid part " << r;
  std::cout << "[ info ] explicit, m_a/m = 4: " << said.substr(0, said.find(':'))
            << " in one piece and on 3 fluid parts\n";
}
