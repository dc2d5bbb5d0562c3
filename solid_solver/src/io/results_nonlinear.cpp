// results.h5 output of the Mohr–Coulomb damage material and the rock–lining contact.
#include "results_nonlinear.hpp"

#include "tq/materials/material_mc.hpp"

namespace tq::nlout {

namespace {

int historyIndex(const Material& m, const std::string& name) {
  const auto names = m.historyNames();
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return int(i);
  return -1;
}

// /interface: the pairs and the parameters, written once when the contact is first seen.
void writeInterfaceHeader(hid_t file, const DynamicContact& c, State& st) {
  const ContactPairs& p = c.pairs();
  const hsize_t P = hsize_t(p.size());
  std::vector<Index> pairs(2 * P);
  for (hsize_t k = 0; k < P; ++k) {
    pairs[2 * k] = p.node1[k];
    pairs[2 * k + 1] = p.node2[k];
  }
  h5::writeInts(file, "/interface/pairs", pairs.data(), {P, 2});
  h5::writeDoubles(file, "/interface/normal", p.normal.data(), {P, 3});
  h5::writeDoubles(file, "/interface/area", p.area.data(), {P});
  auto g = h5::openGroup(file, "/interface");
  const ContactParams& cp = c.params();
  h5::writeStringAttr(g, "model", interfaceModelName(cp.model));
  h5::writeDoubleAttr(g, "static_friction", cp.staticFriction);
  h5::writeDoubleAttr(g, "dynamic_friction", cp.dynamicFriction);
  h5::writeDoubleAttr(g, "cohesion", cp.cohesion);
  h5::writeStringAttr(g, "after_failure", afterFailureName(cp.afterFailure));
  h5::writeStringListAttr(g, "states", {"bonded", "separated", "slipping", "stuck", "inactive"});
  // the pair counts are taken from the nearer state, the dissipated energy interpolated
  st.interfaceHistory =
      h5::ClockedRows(h5::RowAppender(file, "/interface/history", 7, st.ledger), 7, 0, {0, 1, 1, 1, 1, 1, 0});
  h5::writeStringListAttr(g, "history_columns",
                          {"time", "bonded", "separated", "slipping", "stuck", "inactive", "dissipated"});
}

// /joints: the pairs, each joint's plane and area, the law, written once when the joints are first
// seen; /joints/history: per joint its opening (area-weighted mean, largest, smallest), slip (mean,
// largest), axial force and the opening's gradients across the joint (docs/solid_solver.md).
void writeJointsHeader(hid_t file, const LiningJoints& j, State& st) {
  const JointPairs& p = j.pairs();
  const hsize_t P = hsize_t(p.size()), J = hsize_t(p.numJoints());
  std::vector<Index> pairs(2 * P);
  std::vector<Real> area(J, 0.0);
  for (hsize_t k = 0; k < P; ++k) {
    pairs[2 * k] = p.nodeA[k];
    pairs[2 * k + 1] = p.nodeB[k];
    area[size_t(p.joint[k])] += p.area[k];
  }
  h5::writeInts(file, "/joints/pairs", pairs.data(), {P, 2});
  h5::writeInts(file, "/joints/joint", p.joint.data(), {P});
  h5::writeDoubles(file, "/joints/pair_area", p.area.data(), {P});
  h5::writeDoubles(file, "/joints/y", p.y.data(), {J});
  h5::writeDoubles(file, "/joints/area", area.data(), {J});
  auto g = h5::openGroup(file, "/joints");
  const JointParams& jp = j.params();
  h5::writeDoubleAttr(g, "normal_stiffness", jp.normalStiffness);
  h5::writeDoubleAttr(g, "shear_stiffness", jp.shearStiffness);
  h5::writeDoubleAttr(g, "tensile_strength", jp.tensileStrength);
  h5::writeDoubleAttr(g, "friction", jp.friction);
  const hsize_t cols = 1 + kJointColumns * J;
  st.jointHistory = h5::ClockedRows(h5::RowAppender(file, "/joints/history", cols, st.ledger), cols, 0);
  h5::writeStringListAttr(
      g, "history_columns",
      {"time", "opening", "opening_max", "opening_min", "slip", "slip_max", "axial_force", "rotation_x", "rotation_z"});
}

bool updateJoints(hid_t file, const Solver& s, State& st) {
  if (!st.joints) {
    st.joints = findJoints(s);
    if (st.joints) writeJointsHeader(file, *st.joints, st);
  }
  return st.joints != nullptr;
}

bool updateContact(hid_t file, const Solver& s, State& st) {
  if (!st.contact) {
    st.contact = findContact(s);
    if (st.contact) writeInterfaceHeader(file, *st.contact, st);
  }
  return st.contact != nullptr;
}

}  // namespace

void prepare(hid_t file, const Solver& s, State& st) {
  updateContact(file, s, st);
  updateJoints(file, s, st);
}

const LiningJoints* findJoints(const Solver& s) {
  for (const auto& e : s.contributors())
    if (auto* d = dynamic_cast<const LiningJoints*>(e.contributor.get())) return d;
  return nullptr;
}

const DynamicContact* findContact(const Solver& s) {
  for (const auto& e : s.contributors())
    if (auto* d = dynamic_cast<const DynamicContact*>(e.contributor.get())) return d;
  return nullptr;
}

Real elementDamage(const Solver& s, Index block, Index elem) {
  const auto& b = *s.blocks()[size_t(block)];
  const int h = historyIndex(b.material(), "damage");
  return h < 0 ? 0.0 : b.history(h, elem);
}

void addEnergy(hid_t file, State& st) {
  st.dissipation = h5::ClockedRows(h5::RowAppender(file, "/energy/dissipation", 3, st.ledger), 3, 0);
  auto g = h5::openGroup(file, "/energy");
  h5::writeStringListAttr(g, "dissipation_columns", {"time", "plastic", "interface"});
}

void addMonitor(hid_t file, const std::string& g, State& st) {
  st.monitorDamage.emplace_back(h5::RowAppender(file, g + "/damage", 1, st.ledger), 1, -1);
}

void observe(hid_t file, const Solver& s, const std::vector<std::pair<Index, Index>>& monitorElems, State& st) {
  for (size_t m = 0; m < monitorElems.size() && m < st.monitorDamage.size(); ++m) {
    const Real D = elementDamage(s, monitorElems[m].first, monitorElems[m].second);
    st.monitorDamage[m].observe(&D);
  }
  const Real diss[3] = {s.time(), s.energy().plastic, s.energy().interface};
  st.dissipation.observe(diss);
  if (updateContact(file, s, st)) {
    const DynamicContact& c = *st.contact;
    const Real row[7] = {s.time(),
                         Real(c.count(PairState::Bonded)),
                         Real(c.count(PairState::Separated)),
                         Real(c.count(PairState::Slipping)),
                         Real(c.count(PairState::Stuck)),
                         Real(c.count(PairState::Inactive)),
                         c.dissipatedEnergy()};
    st.interfaceHistory.observe(row);
  }
  if (updateJoints(file, s, st)) {
    const auto sum = st.joints->summaries(s.state());
    std::vector<Real> row(1 + kJointColumns * sum.size());
    row[0] = s.time();
    for (size_t j = 0; j < sum.size(); ++j) {
      const JointSummary& o = sum[j];
      const Real v[kJointColumns] = {o.opening, o.openingMax, o.openingMin, o.slip,
                                     o.slipMax, o.axialForce, o.rotationX,  o.rotationZ};
      for (int k = 0; k < kJointColumns; ++k) row[1 + kJointColumns * j + size_t(k)] = v[k];
    }
    st.jointHistory.observe(row.data());
  }
}

void write(double t, double w, State& st) {
  for (auto& m : st.monitorDamage) m.write(t, w);
  st.dissipation.write(t, w);
  if (st.contact) st.interfaceHistory.write(t, w);
  if (st.joints) st.jointHistory.write(t, w);
}

void snapshot(hid_t file, const std::string& g, const Solver& s, State& st) {
  const Mesh& m = s.mesh();
  const Index E = m.numElems();
  bool any = false;
  std::vector<Real> D(size_t(E), 0.0), ep(6 * size_t(E), 0.0), w(size_t(E), 0.0);
  for (const auto& b : s.blocks()) {
    const Material& mat = b->material();
    const int hd = historyIndex(mat, "damage"), hp = historyIndex(mat, "plastic_strain_xx"),
              hw = historyIndex(mat, "dissipation");
    if (hd < 0) continue;
    any = true;
    for (Index e = 0; e < b->numElems(); ++e) {
      const size_t me = size_t(b->meshElem(e));
      D[me] = b->history(hd, e);
      if (hp >= 0)
        for (int k = 0; k < 6; ++k) ep[6 * me + size_t(k)] = b->history(hp + k, e);
      if (hw >= 0) w[me] = b->history(hw, e);
    }
  }
  if (any) {
    h5::writeDoubles(file, g + "/damage", D.data(), {hsize_t(E)});
    h5::writeDoubles(file, g + "/plastic_strain", ep.data(), {hsize_t(E), 6});
    h5::writeDoubles(file, g + "/dissipation", w.data(), {hsize_t(E)});
  }
  if (updateContact(file, s, st)) {
    const DynamicContact& c = *st.contact;
    const Index P = c.numPairs();
    const size_t np = size_t(P);
    std::vector<Index> state(np), failed(np);
    std::vector<Real> opening(np), slip(np), fn(np), ft(np);
    for (Index p = 0; p < P; ++p) {
      state[size_t(p)] = Index(c.state(p));
      failed[size_t(p)] = c.failed(p) ? 1 : 0;
      opening[size_t(p)] = c.opening(p, s.state());
      slip[size_t(p)] = c.slip(p, s.state());
      fn[size_t(p)] = c.normalForce(p);
      ft[size_t(p)] = c.tangentialForce(p);
    }
    const hsize_t n = hsize_t(P);
    h5::writeInts(file, g + "/interface/state", state.data(), {n});
    h5::writeInts(file, g + "/interface/failed", failed.data(), {n});
    h5::writeDoubles(file, g + "/interface/opening", opening.data(), {n});
    h5::writeDoubles(file, g + "/interface/slip", slip.data(), {n});
    h5::writeDoubles(file, g + "/interface/normal_force", fn.data(), {n});
    h5::writeDoubles(file, g + "/interface/tangential_force", ft.data(), {n});
  }
}

}  // namespace tq::nlout
