// results.h5 writer (layout in docs/solid_solver.md, "Output").
#include "tq/io/results.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "h5util.hpp"
#include "results_nonlinear.hpp"
#include "tq/io/ring_forces.hpp"

namespace tq {

namespace {
// File space held beyond each write's own data: new object headers, heap and index nodes.
constexpr hsize_t kMetadataMargin = 64 * 1024;
// Held beside the file and freed for the writes that end a run stopped by a full disk.
constexpr hsize_t kStopReserve = 128 * 1024;
// The datasets of a ring's histories: the design forces and diameter changes (float32, with
// envelopes: the first kEnveloped), then the free-body forces (float64: their equilibrium holds to
// round-off, which float32's 7 digits would hide).
constexpr int kRingQ = 7, kEnveloped = 4;
const char* const kRingNames[kRingQ] = {"N", "M", "V", "diameter_change", "free_body/N", "free_body/M", "free_body/V"};
}  // namespace

void principalStresses(const Real s[6], Real p[3]) {
  Eigen::Matrix3d m;
  m << s[XX], s[XY], s[ZX], s[XY], s[YY], s[YZ], s[ZX], s[YZ], s[ZZ];
  // The iterative (QR) solver: its eigenvalues move by no more than the stress does. The closed form
  // (computeDirect) loses about half the digits where two principal stresses are nearly equal (a
  // confined column: 1e-9 of the stress between two runs equal to 1e-13).
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(m, Eigen::EigenvaluesOnly);
  for (int i = 0; i < 3; ++i) p[i] = es.eigenvalues()(i);  // ascending
}

struct ResultsWriter::Impl {
  struct Monitor {
    std::string name;
    Index node = -1, block = -1, elem = -1;
    h5::ClockedRows time, u, v, a, stress, principal;
  };
  h5::Handle file;
  std::string path;
  h5::SpaceLedger ledger;
  std::unique_ptr<h5::SpaceGuard> guard;
  Real lastSample = -1;
  long long samples = 0;
  h5::OutputClock clock;  // the histories' times: k x monitor_dt (h5util.hpp)
  std::vector<Monitor> monitors;
  h5::ClockedRows energy;
  int snapshots = 0;
  nlout::State nl;                                                        // damage and interface output
  std::vector<std::pair<Index, Index>> monElems;                          // (block, element) of each monitor
  std::vector<std::pair<h5::ClockedRows, std::function<Real()>>> series;  // addSeries
  // Lining section forces (tq/io/ring_forces.hpp): per ring its histories (the design N, M, V, the
  // diameter changes, the free-body N, M, V: kRingNames) and, per section and quantity of the first
  // kEnveloped, the envelope max, time of max, min, time of min.
  struct RingOut {
    std::string group;
    h5::RowAppender time, q[kRingQ];
    std::vector<Real> env[kEnveloped];
    size_t count[kRingQ] = {};
    // Rows since the last flush (written at each flush: one HDF5 write per dataset instead of one
    // per sample, which was most of the ring forces' cost).
    std::vector<Real> pendingTime, pending[kRingQ];
    std::vector<Real> prev[kRingQ],
        cur[kRingQ];  // the last two observed states' values (interpolated at the due times)
    size_t samples = 0;
  };
  std::unique_ptr<RingForces> ring;
  std::vector<RingOut> ringOut;
  double ringSeconds = 0;  // wall time spent on the ring forces (evaluation, envelopes, writes)
  void writeRingEnvelopes();
  /// Every history written on the clock, in one order (restart checkpoints).
  std::vector<h5::ClockedRows*> clockedRows() {
    std::vector<h5::ClockedRows*> rows{&energy, &nl.interfaceHistory, &nl.dissipation, &nl.jointHistory};
    for (auto& m : monitors)
      for (auto* r : {&m.time, &m.u, &m.v, &m.a, &m.stress, &m.principal}) rows.push_back(r);
    for (auto& [r, value] : series) rows.push_back(&r);
    for (auto& d : nl.monitorDamage) rows.push_back(&d);
    return rows;
  }
};

void ResultsWriter::Impl::writeRingEnvelopes() {
  const auto t0 = std::chrono::steady_clock::now();
  for (auto& R : ringOut) {
    R.time.append(R.pendingTime.data(), R.pendingTime.size());
    for (int q = 0; q < kRingQ; ++q)
      if (R.count[q] > 0) R.q[q].append(R.pending[q].data(), R.pendingTime.size());
    R.pendingTime.clear();
    for (auto& p : R.pending) p.clear();
    if (R.samples == 0) continue;
    for (int q = 0; q < kEnveloped; ++q)
      if (R.count[q] > 0)
        h5::replaceDoubles(file, R.group + "/envelope/" + kRingNames[q], R.env[q].data(), {R.count[q], 4});
    if (R.count[3] > 0) {  // ovaling: the largest elongation and shortening of a diameter so far
      const auto& e = R.env[3];
      size_t imax = 0, imin = 0;
      for (size_t k = 1; k < R.count[3]; ++k) {
        if (e[4 * k] > e[4 * imax]) imax = k;
        if (e[4 * k + 2] < e[4 * imin + 2]) imin = k;
      }
      const auto angles = h5::readDoubles(file, R.group + "/diameter_angle");
      auto g = h5::openGroup(file, R.group);
      h5::writeDoubleAttr(g, "ovaling_elongation", e[4 * imax]);
      h5::writeDoubleAttr(g, "ovaling_elongation_angle", angles[imax]);
      h5::writeDoubleAttr(g, "ovaling_elongation_time", e[4 * imax + 1]);
      h5::writeDoubleAttr(g, "ovaling_shortening", e[4 * imin + 2]);
      h5::writeDoubleAttr(g, "ovaling_shortening_angle", angles[imin]);
      h5::writeDoubleAttr(g, "ovaling_shortening_time", e[4 * imin + 3]);
    }
  }
  if (ring) {
    ringSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    auto g = h5::openGroup(file, "/ring_forces");
    h5::writeDoubleAttr(g, "wall_s", ringSeconds);
  }
}

ResultsWriter::ResultsWriter(const std::string& path, const SolidInput& in, const Solver& s)
    : impl_(std::make_unique<Impl>()) {
  auto& I = *impl_;
  I.path = path;
  I.clock = h5::OutputClock(in.monitorDt);
  I.file = h5::createFile(path);
  hid_t f = I.file;
  const Mesh& m = s.mesh();
  I.guard = std::make_unique<h5::SpaceGuard>(f, path, kStopReserve);
  I.nl.ledger = &I.ledger;
  I.guard->reserve(24 * hsize_t(m.numNodes()) + 36 * hsize_t(m.numElems()) + 2 * kMetadataMargin);
  h5::writeStringAttr(f, "format", "tunnelquake-solid-results");
  h5::writeIntAttr(f, "version", 1);
  h5::writeStringAttr(f, "status", "running");
  h5::writeStringAttr(f, "input", in.path);
  h5::writeStringAttr(f, "mesh", in.meshPath);
  if (!in.staged.inputFingerprint.empty()) h5::writeStringAttr(f, "input_fingerprint", in.staged.inputFingerprint);
  h5::writeStringAttr(f, "integrator", integratorName(s.options().integrator));
  h5::writeStringAttr(f, "formulation", formulationName(in.formulation));
  const StableStep st = s.stableStep();
  h5::writeDoubleAttr(f, "dt", s.dt());
  h5::writeDoubleAttr(f, "dt_critical", st.dtCritical);
  h5::writeDoubleAttr(f, "rayleigh_alpha", s.options().damping.alpha);
  h5::writeDoubleAttr(f, "rayleigh_beta", s.options().damping.beta);
  h5::writeDoubles(f, "/mesh/coordinates", m.coords.data(), {m.coords.size() / 3, 3});
  h5::writeInts(f, "/mesh/connectivity", m.connectivity.data(), {m.connectivity.size() / 8, 8});
  h5::writeInts(f, "/mesh/region", m.region.data(), {m.region.size()});
  {
    auto g = h5::openGroup(f, "/mesh");
    h5::writeStringListAttr(g, "regions", m.regionNames);
  }
  // Monitors: nearest node; element whose centroid is nearest (for stresses).
  for (const auto& mi : in.monitors) {
    Impl::Monitor mon;
    mon.name = mi.name;
    Real best = std::numeric_limits<Real>::max();
    for (Index n = 0; n < m.numNodes(); ++n) {
      Real d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += std::pow(m.coords[dofIndex(n, k)] - mi.point[k], 2);
      if (d2 < best) {
        best = d2;
        mon.node = n;
      }
    }
    best = std::numeric_limits<Real>::max();
    const auto& blocks = s.blocks();
    for (size_t b = 0; b < blocks.size(); ++b)
      for (Index e = 0; e < blocks[b]->numElems(); ++e) {
        Real c[3] = {0, 0, 0};
        for (int k = 0; k < 8; ++k)
          for (int d = 0; d < 3; ++d) c[d] += 0.125 * m.coords[dofIndex(blocks[b]->node(e, k), d)];
        Real d2 = 0;
        for (int d = 0; d < 3; ++d) d2 += std::pow(c[d] - mi.point[d], 2);
        if (d2 < best) {
          best = d2;
          mon.block = Index(b);
          mon.elem = e;
        }
      }
    const std::string g = "/monitors/" + mi.name;
    mon.time = h5::ClockedRows(h5::RowAppender(f, g + "/time", 1, &I.ledger), 1, 0);
    mon.u = h5::ClockedRows(h5::RowAppender(f, g + "/u", 3, &I.ledger), 3, -1);
    mon.v = h5::ClockedRows(h5::RowAppender(f, g + "/v", 3, &I.ledger), 3, -1);
    mon.a = h5::ClockedRows(h5::RowAppender(f, g + "/a", 3, &I.ledger), 3, -1);
    mon.stress = h5::ClockedRows(h5::RowAppender(f, g + "/stress", 6, &I.ledger), 6, -1);
    mon.principal = h5::ClockedRows(h5::RowAppender(f, g + "/principal", 3, &I.ledger), 3, -1);
    auto gg = h5::openGroup(f, g);
    h5::writeIntAttr(gg, "node", mon.node);
    h5::writeIntAttr(gg, "element", blocks[size_t(mon.block)]->meshElem(mon.elem));
    h5::writeDoubleAttr(gg, "x", mi.point[0]);
    h5::writeDoubleAttr(gg, "y", mi.point[1]);
    h5::writeDoubleAttr(gg, "z", mi.point[2]);
    nlout::addMonitor(f, g, I.nl);
    I.monElems.emplace_back(mon.block, mon.elem);
    I.monitors.push_back(std::move(mon));
  }
  // Lining section forces: one ring per axial element layer of the lining at the monitors.
  const std::string liningName = in.staged.stages.liningRegion;
  const ElementBlock* lining = nullptr;
  for (const auto& b : s.blocks())
    if (b->name() == liningName) lining = b.get();
  if (in.ringForces && lining) {
    std::vector<Real> ys;
    for (const auto& mi : in.monitors) ys.push_back(mi.point[1]);
    I.ring = std::make_unique<RingForces>(m, *lining, ys);
    auto g = h5::ensureGroup(f, "/ring_forces");
    h5::writeStringAttr(g, "lining_region", liningName);
    h5::writeIntAttr(g, "rings", (long long)I.ring->rings().size());
    if (!I.ring->note().empty()) h5::writeStringAttr(g, "note", I.ring->note());
    h5::writeStringAttr(
        g, "convention",
        "per unit length of tunnel; N = integral of s_tt dr (tension +), M = integral of s_tt (r_mid - r) dr "
        "(+ = tension at the inner face), V = integral of s_rt dr; angle from +x towards +z about the "
        "ring centre; diameter_change: elongation + (m), relative to the seismic start");
    for (size_t r = 0; r < I.ring->rings().size(); ++r) {
      const LiningRing& R = I.ring->rings()[r];
      Impl::RingOut o;
      o.group = "/ring_forces/" + std::to_string(r);
      auto rg = h5::ensureGroup(f, o.group);
      h5::writeDoubleAttr(rg, "y_min", R.yMin);
      h5::writeDoubleAttr(rg, "y_max", R.yMax);
      h5::writeDoubleAttr(rg, "centre_x", R.xc);
      h5::writeDoubleAttr(rg, "centre_z", R.zc);
      h5::writeDoubleAttr(rg, "r_inner", R.rInner);
      h5::writeDoubleAttr(rg, "r_outer", R.rOuter);
      h5::writeDoubleAttr(rg, "r_mid", R.rMid);
      h5::writeIntAttr(rg, "closed", R.closed ? 1 : 0);
      h5::writeDoubles(f, o.group + "/angle", R.angle.data(), {R.angle.size()});
      if (!R.diameters.empty())
        h5::writeDoubles(f, o.group + "/diameter_angle", R.diameterAngle.data(), {R.diameterAngle.size()});
      o.time = h5::RowAppender(f, o.group + "/time", 1, &I.ledger);
      const size_t S = R.angle.size(), D = R.diameters.size();
      for (int q = 0; q < kRingQ; ++q) {
        o.count[q] = q == 3 ? D : S;
        if (o.count[q] == 0) continue;
        const bool enveloped = q < kEnveloped;
        o.q[q] = h5::RowAppender(f, o.group + "/" + kRingNames[q], o.count[q], &I.ledger, 256, enveloped);
        if (!enveloped) continue;
        o.env[q].assign(4 * o.count[q], 0.0);
        for (size_t k = 0; k < o.count[q]; ++k) {
          o.env[q][4 * k] = -std::numeric_limits<Real>::infinity();
          o.env[q][4 * k + 2] = std::numeric_limits<Real>::infinity();
        }
      }
      auto fb = h5::ensureGroup(f, o.group + "/free_body");
      h5::writeStringAttr(fb, "meaning",
                          "the discrete ring's section forces (N, M, V as above; M about the middle of the section's "
                          "straight radial segment): the force and moment each element column transmits, from its "
                          "elements' internal nodal forces at the displacement of the observed state; between any two "
                          "sections they balance the nodal loads of the lining nodes between them (interface, water, "
                          "inertia) to round-off. The design forces N, M, V (stress resultants) differ from them by "
                          "O(dtheta^2): docs/theory.md section 7");
      I.ringOut.push_back(std::move(o));
    }
  }
  I.energy = h5::ClockedRows(h5::RowAppender(f, "/energy/history", 7, &I.ledger), 7, 0);
  auto eg = h5::openGroup(f, "/energy");
  h5::writeStringListAttr(eg, "columns", {"time", "kinetic", "internal", "damping", "boundary", "external", "error"});
  nlout::addEnergy(f, I.nl);
  flush();
}

ResultsWriter::~ResultsWriter() {
  auto& I = *impl_;
  bool flushed = false;  // the file ends at the EOA of this flush: what is past it was only held
  try {
    flush();
    flushed = true;
  } catch (const OutputError&) {
  }
  // every dataset closed before the file, so that closing the file closes it on disk
  I.series.clear();
  I.monitors.clear();
  I.energy = {};
  I.nl = {};
  I.file.reset();
  if (flushed && I.guard) I.guard->trimClosed();
}

void ResultsWriter::reserve(unsigned long long bytes) {
  auto& I = *impl_;
  if (I.guard) I.guard->reserve(I.ledger.pending + bytes + kMetadataMargin);
}

void ResultsWriter::sample(const Solver& s) {
  auto& I = *impl_;
  const Real t = s.time();
  // 1. Observe this state: every history's row at t, kept beside the previous state's (the first
  //    observation with the contact writes its header: room for it first).
  reserve(0);
  for (auto& mon : I.monitors) {
    Real u[3], v[3], a[3], st[6], p[3];
    for (int d = 0; d < 3; ++d) {
      u[d] = s.relativeDisplacement(mon.node, d);
      v[d] = s.velocityAt(mon.node, d);
      a[d] = s.state().a(mon.node, d);
    }
    const auto& b = *s.blocks()[size_t(mon.block)];
    for (int c = 0; c < 6; ++c) st[c] = b.stress(mon.elem, c);
    principalStresses(st, p);
    mon.time.observe(&t);
    mon.u.observe(u);
    mon.v.observe(v);
    mon.a.observe(a);
    mon.stress.observe(st);
    mon.principal.observe(p);
  }
  const EnergyBalance& e = s.energy();
  const Real row[7] = {t, e.kinetic, e.internal, e.damping, e.boundary, e.external, e.error};
  I.energy.observe(row);
  for (auto& [rows, value] : I.series) {
    const Real r[2] = {t, value()};
    rows.observe(r);
  }
  nlout::observe(I.file, s, I.monElems, I.nl);
  const auto t0 = std::chrono::steady_clock::now();
  for (size_t r = 0; I.ring && r < I.ringOut.size(); ++r) {
    auto& o = I.ringOut[r];
    for (int k = 0; k < kRingQ; ++k) {
      o.prev[k].swap(o.cur[k]);
      o.cur[k].assign(o.count[k], 0.0);
    }
    I.ring->sectionForces(r, o.cur[0].data(), o.cur[1].data(), o.cur[2].data());
    I.ring->diameterChanges(
        r, [&](Index n, int d) { return s.relativeDisplacement(n, d); }, o.cur[3].data());
    I.ring->freeBodyForces(r, s.state().uData(), o.cur[4].data(), o.cur[5].data(), o.cur[6].data());
    for (int k = 0; k < kRingQ; ++k)
      if (o.prev[k].empty()) o.prev[k] = o.cur[k];
  }
  auto ringTime = [&I](std::chrono::steady_clock::time_point from) {
    if (I.ring) I.ringSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - from).count();
  };
  ringTime(t0);
  // 2. Write the rows of the requested times this state completes, each interpolated between the
  //    previous observed state and this one.
  I.clock.observe(t);
  // The solver sums the kinetic energy only at the states its time loop asks for
  // (Solver::setKineticEnergyWanted): a row due now from a state without it would be NaN.
  if (!I.clock.due().empty() && !I.energy.keptFinite(1))
    throw std::logic_error(
        "the energy balance was not summed at a state the histories sample (t = " + std::to_string(t) +
        " s): the time loop did not ask for the kinetic energy there; "
        "this is a defect of tq-solid, please report it with the input file");
  for (const auto& [tk, w] : I.clock.due()) {
    reserve(I.ledger.nextRow);
    for (auto& mon : I.monitors)
      for (auto* rows : {&mon.time, &mon.u, &mon.v, &mon.a, &mon.stress, &mon.principal}) rows->write(tk, w);
    I.energy.write(tk, w);
    for (auto& sr : I.series) sr.first.write(tk, w);
    nlout::write(tk, w, I.nl);
    const auto t1 = std::chrono::steady_clock::now();
    for (size_t r = 0; I.ring && r < I.ringOut.size(); ++r) {
      auto& o = I.ringOut[r];
      o.pendingTime.push_back(tk);
      ++o.samples;
      for (int k = 0; k < kRingQ; ++k) {
        Real* env = k < kEnveloped ? o.env[k].data() : nullptr;
        for (size_t j = 0; j < o.count[k]; ++j) {
          const Real q = o.prev[k][j] + w * (o.cur[k][j] - o.prev[k][j]);
          o.pending[k].push_back(q);
          if (!env) continue;
          if (q > env[4 * j]) {
            env[4 * j] = q;
            env[4 * j + 1] = tk;
          }
          if (q < env[4 * j + 2]) {
            env[4 * j + 2] = q;
            env[4 * j + 3] = tk;
          }
        }
      }
    }
    ringTime(t1);
    I.lastSample = tk;
    ++I.samples;
  }
}

Real ResultsWriter::nextSampleTime() const { return impl_->clock.next(); }

void ResultsWriter::addSeries(const std::string& path, std::function<Real()> value, const std::string& unit) {
  auto& I = *impl_;
  reserve(0);
  I.series.emplace_back(h5::ClockedRows(h5::RowAppender(I.file, path, 2, &I.ledger), 2, 0), std::move(value));
  h5::Handle ds(H5Dopen2(I.file, path.c_str(), H5P_DEFAULT), H5Dclose);
  h5::writeStringListAttr(ds, "columns", {"time", unit});
  flush();
}

void ResultsWriter::addWaterPressure(const Mesh& m, const std::string& face, const std::vector<MonitorInput>& monitors,
                                     const std::vector<Index>& nodes, std::function<const std::vector<Real>&()> force) {
  // Tributary area vectors of the face nodes: a quarter of each quad's area vector (the quads are
  // counter-clockwise seen from outside the solid, so the vector points into the water). A is the
  // length of the summed vector, so a uniform pressure p, whose nodal forces are −p × this vector,
  // is recovered exactly.
  std::vector<Real> areaVec(3 * nodes.size(), 0.0);
  const auto& quads = m.faces.at(face);
  auto local = [&](Index n) { return size_t(std::lower_bound(nodes.begin(), nodes.end(), n) - nodes.begin()); };
  auto x = [&](Index n, int d) { return m.coords[dofIndex(n, d)]; };
  for (size_t q = 0; q + 3 < quads.size(); q += 4) {
    Real s[3];
    quadAreaVector(m, &quads[q], s);
    for (int k = 0; k < 4; ++k) {
      const size_t j = local(quads[q + size_t(k)]);
      if (j >= nodes.size() || nodes[j] != quads[q + size_t(k)]) continue;
      for (int d = 0; d < 3; ++d) areaVec[3 * j + size_t(d)] += 0.25 * s[d];
    }
  }
  for (const auto& mi : monitors) {
    size_t best = 0;
    Real bestD2 = std::numeric_limits<Real>::max();
    for (size_t j = 0; j < nodes.size(); ++j) {
      Real d2 = 0;
      for (int d = 0; d < 3; ++d) d2 += std::pow(x(nodes[j], d) - mi.point[d], 2);
      if (d2 < bestD2) {
        bestD2 = d2;
        best = j;
      }
    }
    const Real len = nodes.empty() ? 0.0
                                   : std::sqrt(std::pow(areaVec[3 * best], 2) + std::pow(areaVec[3 * best + 1], 2) +
                                               std::pow(areaVec[3 * best + 2], 2));
    if (len <= 0) continue;
    const std::array<Real, 3> n = {areaVec[3 * best] / len, areaVec[3 * best + 1] / len, areaVec[3 * best + 2] / len};
    const std::string g = "/monitors/" + mi.name;
    {
      reserve(0);
      auto gg = h5::ensureGroup(impl_->file, g);
      h5::writeIntAttr(gg, "water_node", nodes[best]);
      h5::writeDoubleAttr(gg, "water_area", len);
      h5::writeDoubleAttr(gg, "water_nx", n[0]);
      h5::writeDoubleAttr(gg, "water_ny", n[1]);
      h5::writeDoubleAttr(gg, "water_nz", n[2]);
    }
    addSeries(
        g + "/water_pressure",
        [force, n, j = best, A = len] {
          const auto& F = force();
          return -(F[3 * j] * n[0] + F[3 * j + 1] * n[1] + F[3 * j + 2] * n[2]) / A;
        },
        "water_pressure");
  }
}

void ResultsWriter::writeAttrs(const std::string& group, const std::map<std::string, double>& numbers,
                               const std::map<std::string, std::string>& texts) {
  reserve(0);
  auto g = h5::ensureGroup(impl_->file, group);
  for (const auto& [k, v] : numbers) h5::writeDoubleAttr(g, k, v);
  for (const auto& [k, v] : texts) h5::writeStringAttr(g, k, v);
  flush();
}

void ResultsWriter::snapshot(const Solver& s) {
  auto& I = *impl_;
  const std::string g = "/snapshots/" + std::to_string(I.snapshots++);
  const Mesh& m = s.mesh();
  const Index N = m.numNodes(), E = m.numElems();
  // u, v [N, 3], stress [E, 6]; damage, dissipation [E], plastic strain [E, 6]; 6 values a contact pair
  const auto* contact = nlout::findContact(s);
  reserve(I.ledger.nextRow + 48 * hsize_t(N) + 112 * hsize_t(E) + 48 * hsize_t(contact ? contact->numPairs() : 0) +
          kMetadataMargin);
  std::vector<Real> u(3 * size_t(N)), v(3 * size_t(N)), st(6 * size_t(E), 0.0);
  for (Index n = 0; n < N; ++n)
    for (int d = 0; d < 3; ++d) {
      u[dofIndex(n, d)] = s.relativeDisplacement(n, d);
      v[dofIndex(n, d)] = s.velocityAt(n, d);
    }
  for (const auto& b : s.blocks())
    for (Index e = 0; e < b->numElems(); ++e)
      for (int c = 0; c < 6; ++c) st[6 * size_t(b->meshElem(e)) + c] = b->stress(e, c);
  h5::writeDoubles(I.file, g + "/u", u.data(), {hsize_t(N), 3});
  h5::writeDoubles(I.file, g + "/v", v.data(), {hsize_t(N), 3});
  h5::writeDoubles(I.file, g + "/stress", st.data(), {hsize_t(E), 6});
  nlout::snapshot(I.file, g, s, I.nl);
  auto gg = h5::openGroup(I.file, g);
  h5::writeDoubleAttr(gg, "time", s.time());
  flush();
}

void ResultsWriter::setStatus(const std::string& status) {
  reserve(0);
  h5::writeStringAttr(impl_->file, "status", status);
  flush();
}

bool ResultsWriter::stopAfterOutputError(const std::string& status) {
  auto& I = *impl_;
  if (I.guard) I.guard->release();
  try {
    h5::writeStringAttr(I.file, "status", status);
    flush();
  } catch (const OutputError&) {
    return false;
  }
  return true;
}

double ResultsWriter::lastSampleTime() const { return impl_->lastSample; }
long long ResultsWriter::samples() const { return impl_->samples; }

void ResultsWriter::writeTimings(double wall, long long steps, long long elementSteps, int threads) {
  reserve(0);
  auto g = h5::ensureGroup(impl_->file, "/timings");
  h5::writeDoubleAttr(g, "wall_s", wall);
  h5::writeIntAttr(g, "steps", steps);
  h5::writeIntAttr(g, "element_steps", elementSteps);
  h5::writeIntAttr(g, "threads", threads);
  h5::writeDoubleAttr(g, "us_per_element_step", elementSteps > 0 ? 1e6 * wall / double(elementSteps) : 0.0);
  flush();
}

void ResultsWriter::writeStage(const std::string& name, long long steps, double ratio, bool converged,
                               double wallSeconds, const std::string& note) {
  reserve(0);
  auto root = h5::ensureGroup(impl_->file, "/stages");
  const std::string path = "/stages/" + std::to_string(h5::members(root).size()) + "_" + name;
  auto g = h5::ensureGroup(impl_->file, path);
  h5::writeIntAttr(g, "steps", steps);
  h5::writeDoubleAttr(g, "unbalanced_ratio", ratio);
  h5::writeIntAttr(g, "converged", converged ? 1 : 0);
  h5::writeDoubleAttr(g, "wall_s", wallSeconds);
  h5::writeStringAttr(g, "note", note);
  flush();
}

void ResultsWriter::flush() {
  auto& I = *impl_;
  I.writeRingEnvelopes();
  if (I.guard) I.guard->reserve(I.ledger.pending + kMetadataMargin);
  if (H5Fflush(I.file, H5F_SCOPE_GLOBAL) < 0)
    throw OutputError("cannot flush the results to " + h5::writeFailure(I.file));
  I.ledger.pending = 0;
  if (I.guard) I.guard->flushed();
}

}  // namespace tq

namespace tq {

const std::string& ResultsWriter::path() const { return impl_->path; }

void ResultsWriter::checkpoint(StateArchive& a) {
  auto& I = *impl_;
  a.io(I.samples);
  a.io(I.lastSample);
  a.io(I.snapshots);
  // the even clock: where it stands and the two states the next rows are interpolated between
  I.clock.checkpoint(a);
  for (auto* r : I.clockedRows()) r->checkpoint(a);
  for (auto& R : I.ringOut) {
    a.io(R.samples);
    for (auto& e : R.env) a.io(e);
    for (int q = 0; q < kRingQ; ++q) {
      a.io(R.prev[q]);
      a.io(R.cur[q]);
    }
  }
}

void ResultsWriter::resumeFrom(const std::string& copy, const Solver& solver) {
  auto& I = *impl_;
  const h5::Handle src = h5::openFile(copy);
  // prepare() makes the interface history's rows when it first meets the contact: the two states
  // restored into them from the checkpoint are carried over
  StateArchive kept;
  kept.beginSave();
  I.nl.interfaceHistory.checkpoint(kept);
  I.nl.jointHistory.checkpoint(kept);
  kept.end();
  nlout::prepare(I.file, solver, I.nl);
  kept.beginRestore();
  I.nl.interfaceHistory.checkpoint(kept);
  I.nl.jointHistory.checkpoint(kept);
  kept.end();
  std::vector<h5::RowAppender*> rows;
  for (auto* r : I.clockedRows()) rows.push_back(&r->appender());
  for (auto& R : I.ringOut) {
    rows.push_back(&R.time);
    for (auto& q : R.q) rows.push_back(&q);
  }
  for (auto* r : rows) {
    if (!r->valid()) continue;
    reserve(0);
    r->appendFrom(src);
  }
  for (int k = 0; k < I.snapshots; ++k) {
    const std::string g = "/snapshots/" + std::to_string(k);
    h5::ensureGroup(I.file, "/snapshots");
    if (H5Ocopy(src, g.c_str(), I.file, g.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0)
      throw OutputError("cannot copy snapshot " + g + " from " + copy + ": " + h5::writeFailure(I.file));
  }
  flush();
}

}  // namespace tq
