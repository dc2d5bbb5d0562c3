// A participant in parts (Participant::setPart): the first participant split over several
// processes, each with its own nodes and its own connection, against the same coupling in one
// piece. The added-mass oscillators of test_participant.cpp, one per node with its own stiffness,
// implicit with Aitken and IQN-ILS: the partner measures, accelerates and decides on the whole
// interface, so the pass count of every window and every value hang on every node's.
#include <cmath>
#include <map>
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
  std::vector<unsigned char> fluid;
  std::vector<double> vOld;
};

/// The oscillators' run: x of every node at every window's end ([window][node], nodes in the
/// ring's order), the passes of every window, and what each part held.
struct PartsRun {
  std::vector<std::vector<double>> x;
  std::vector<int> passes;
  std::vector<std::size_t> partNodes;      ///< nodes each part exchanged
  std::vector<std::size_t> partnerParts;   ///< the fluid's count of the solid's parts
  std::vector<std::exception_ptr> errors;  ///< the parts', then the fluid's
  PartsSaved saved;                        ///< at the end of window `saveAt`
};

/// The node's part: interleaved around the ring (each part holds several separate arcs).
int partOf(int node, int parts) { return (node / 3 + node % 2) % parts; }

/// The solid in `parts` parts (threads) and the fluid in one piece, partOf() the part of each node;
/// `also` one node a second part claims too (−1: none); `emptyLast`: the last part holds no node;
/// `saveAt`: every side saves its state at that window's end and runs on (0: none); `resume`: every
/// side starts from those states (initializeResumed) instead.
PartsRun coupleInParts(int parts, AccelerationKind acc, int windows, int also = -1, bool emptyLast = false,
                       int saveAt = 0, const PartsSaved* resume = nullptr) {
  const int used = emptyLast ? parts - 1 : parts;  // the parts that hold nodes
  const auto dir = freshDir();
  auto c = ringConfig(SchemeKind::Implicit, std::uint64_t(windows));
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
  out.errors.assign(std::size_t(parts) + 1, nullptr);
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
  auto fluid = [&] {
    Participant p("fluid", c, tcp(dir), "tok-parts");
    setRing(p, r, false);
    std::vector<double> vOld(3 * std::size_t(n), 0.0), vs, vNew, f(3 * std::size_t(n));
    if (resume) {
      p.initializeResumed(resume->fluid);
      vOld = resume->vOld;
    } else {
      p.initialize();
    }
    out.partnerParts.push_back(p.partnerParts());
    while (p.isCouplingOngoing()) {
      if (p.requiresWritingCheckpoint()) vs = vOld;
      p.readData("wall", "velocity", vNew);
      for (std::size_t i = 0; i < f.size(); ++i) f[i] = -ma * (vNew[i] - vOld[i]) / dt;
      p.writeData("wall", "force", f);
      p.advance(dt);
      vOld = p.requiresReadingCheckpoint() ? vs : vNew;
      if (p.isTimeWindowComplete() && int(p.state().window) == saveAt)
        out.saved.fluid = p.saveState(), out.saved.vOld = vOld;
    }
    p.finalize();
  };
  std::vector<std::thread> threads;
  for (int part = 0; part < parts; ++part)
    threads.emplace_back([&, part] {
      try {
        solidPart(part);
      } catch (...) {
        out.errors[std::size_t(part)] = std::current_exception();
      }
    });
  try {
    fluid();
  } catch (...) {
    out.errors.back() = std::current_exception();
  }
  for (auto& t : threads) t.join();
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
  second.setPart(1, 2);
  setRing(second, r, false);
  try {
    second.initialize();
    FAIL() << "the second participant in parts was accepted";
  } catch (const ConfigError& e) {
    EXPECT_TRUE(contains(e.what(), "in 2 parts: it must be the configuration's first participant")) << e.what();
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
      ASSERT_FALSE(whole.saved.fluid.empty());
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
