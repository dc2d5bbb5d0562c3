// Test fixtures for the solid's inputs: solid_input.h5 from an in-memory SolidInput, every attribute
// named by the generated table's constants (solid_solver/src/input_schema.inc), so no list of keys
// of its own (the Python writer, tunnelquake.solid_input, writes the real ones); the pieces of a
// SolidInput the tests share (a sudden pressure load, the in-situ stage under gravity); an input
// refused with a message that names what is wrong.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "io/h5util.hpp"
#include "io/input_schema.hpp"
#include "tq/io/input.hpp"

namespace tq::test {

namespace K = input_schema::key;

/// `run()` is refused with an InputError whose message names each of `parts` (the test fails with
/// `accepted` when it is not refused).
template <class Run>
void expectInputError(Run&& run, const std::string& accepted, const std::vector<std::string>& parts) {
  try {
    run();
    ADD_FAILURE() << accepted;
  } catch (const InputError& e) {
    const std::string msg = e.what();
    for (const auto& part : parts) EXPECT_NE(msg.find(part), std::string::npos) << msg;
  }
}

/// Staged input with the stages `sequence`, in_situ among them: the in-situ stress under gravity g
/// (also the run's body force −g ẑ) with the stress ratios kx, ky, kz. Returns the staged input
/// for the rest of the set-up.
inline StagedInput& inSituUnderGravity(SolidInput& in, std::vector<std::string> sequence, Real g, Real kx = 1,
                                       Real ky = 1, Real kz = 1) {
  StagedInput& S = in.staged;
  S.present = true;
  S.stages.sequence = std::move(sequence);
  S.inSitu.present = true;
  S.inSitu.kx = kx;
  S.inSitu.ky = ky;
  S.inSitu.kz = kz;
  S.inSitu.gravity = g;
  in.options.gravity[2] = -g;
  return S;
}

/// A load "pressure" of `force` (N) along z over the face group `target`, on at once (within 1 ns)
/// and held.
inline LoadInput suddenPressure(const std::string& target, Real force) {
  LoadInput l;
  l.name = "pressure";
  l.target = target;
  l.direction = 2;
  l.force = force;
  l.function = {{0.0, 1e-9, 1.0}, {0.0, 1.0, 1.0}};
  return l;
}

inline void writeStagedGroups(hid_t f, const SolidInput& in) {
  const StagedInput& S = in.staged;
  if (!S.condition.empty()) h5::writeStringAttr(f, K::root::condition.name, S.condition);
  {
    auto g = h5::ensureGroup(f, "/stages");
    std::string seq;
    for (const auto& s : S.stages.sequence) seq += (seq.empty() ? "" : ",") + s;
    h5::writeStringAttr(g, K::stages::sequence.name, seq);
    h5::writeDoubleAttr(g, K::stages::relaxation_tolerance.name, S.stages.tolerance);
    h5::writeIntAttr(g, K::stages::relaxation_max_steps.name, S.stages.maxSteps);
    h5::writeIntAttr(g, K::stages::mass_scaling.name, S.stages.massScaling ? 1 : 0);
    h5::writeIntAttr(g, K::stages::equilibrium_correction.name, S.stages.equilibriumCorrection ? 1 : 0);
    h5::writeStringAttr(g, K::stages::lining_region.name, S.stages.liningRegion);
    h5::writeDoubleAttr(g, K::stages::release_fraction.name, S.stages.releaseFraction);
  }
  if (S.inSitu.present) {
    auto g = h5::ensureGroup(f, "/in_situ");
    const InSituInput& I = S.inSitu;
    h5::writeDoubleAttr(g, K::in_situ::kx.name, I.kx);
    h5::writeDoubleAttr(g, K::in_situ::ky.name, I.ky);
    h5::writeDoubleAttr(g, K::in_situ::kz.name, I.kz);
    h5::writeDoubleAttr(g, K::in_situ::gravity.name, I.gravity);
    h5::writeDoubleAttr(g, K::in_situ::density.name, I.density);
    if (std::isfinite(I.zTop)) h5::writeDoubleAttr(g, K::in_situ::z_top.name, I.zTop);
    h5::writeDoubleAttr(g, K::in_situ::surcharge.name, I.surcharge);
  }
  if (S.bottom.present) {
    auto g = h5::ensureGroup(f, "/boundaries/bottom");
    const BottomBoundaryInput& B = S.bottom;
    h5::writeStringAttr(g, K::boundaries_bottom::face.name, B.face);
    h5::writeStringAttr(g, K::boundaries_bottom::type.name, "viscoelastic");
    if (B.distance > 0) h5::writeDoubleAttr(g, K::boundaries_bottom::distance.name, B.distance);
    if (B.alphaN > 0) h5::writeDoubleAttr(g, K::boundaries_bottom::alpha_n.name, B.alphaN);
    if (B.alphaT > 0) h5::writeDoubleAttr(g, K::boundaries_bottom::alpha_t.name, B.alphaT);
    if (B.rho > 0) {
      h5::writeDoubleAttr(g, K::boundaries_bottom::rho.name, B.rho);
      h5::writeDoubleAttr(g, K::boundaries_bottom::cp.name, B.cp);
      h5::writeDoubleAttr(g, K::boundaries_bottom::cs.name, B.cs);
    }
    if (!B.columnFace.empty()) h5::writeStringAttr(g, K::boundaries_bottom::column_face.name, B.columnFace);
  }
  if (S.freeField.present) {
    auto g = h5::ensureGroup(f, "/boundaries/free_field");
    h5::writeStringListAttr(g, K::boundaries_free_field::faces.name, S.freeField.faces);
  }
  if (S.rockLining.present) {
    auto g = h5::ensureGroup(f, "/interfaces/rock_lining");
    const InterfaceInput& R = S.rockLining;
    h5::writeStringAttr(g, K::interfaces_rock_lining::model.name, R.model);
    h5::writeDoubleAttr(g, K::interfaces_rock_lining::static_friction.name, R.staticFriction);
    h5::writeDoubleAttr(g, K::interfaces_rock_lining::dynamic_friction.name, R.dynamicFriction);
    h5::writeDoubleAttr(g, K::interfaces_rock_lining::cohesion.name, R.cohesion);
    h5::writeStringAttr(g, K::interfaces_rock_lining::after_failure.name, R.afterFailure);
  }
  if (S.motion.present) {
    auto g = h5::ensureGroup(f, "/motion");
    const MotionInput& M = S.motion;
    h5::writeDoubles(g, K::motion::time.name, M.time.data(), {M.time.size()});
    if (!M.ax.empty()) h5::writeDoubles(g, K::motion::ax.name, M.ax.data(), {M.ax.size()});
    if (!M.ay.empty()) h5::writeDoubles(g, K::motion::ay.name, M.ay.data(), {M.ay.size()});
    if (!M.az.empty()) h5::writeDoubles(g, K::motion::az.name, M.az.data(), {M.az.size()});
    if (M.cutoffFrequency > 0) h5::writeDoubleAttr(g, K::motion::cutoff_frequency.name, M.cutoffFrequency);
    if (!M.convention.empty()) h5::writeStringAttr(g, K::motion::convention.name, M.convention);
  }
}

inline void writeInputFile(const SolidInput& in, const std::string& path, const std::string& meshAttr) {
  auto f = h5::createFile(path);
  h5::writeStringAttr(f, K::root::format.name, input_schema::kFormat);
  h5::writeIntAttr(f, K::root::version.name, input_schema::kVersion);
  h5::writeStringAttr(f, K::root::mesh.name, meshAttr);
  {
    auto g = h5::ensureGroup(f, "/solver");
    h5::writeDoubleAttr(g, K::solver::t_end.name, in.tEnd);
    h5::writeDoubleAttr(g, K::solver::dt.name, in.options.dt);
    h5::writeDoubleAttr(g, K::solver::safety.name, in.options.safety);
    h5::writeDoubleAttr(g, K::solver::velocity_limit.name, in.options.velocityLimit);
    h5::writeDoubleAttr(g, K::solver::gravity_z.name, in.options.gravity[2]);
    if (in.options.subcyclingLevels > 0)
      h5::writeDoubleAttr(g, K::solver::subcycling_levels.name, in.options.subcyclingLevels);
    h5::writeStringAttr(g, K::solver::integrator.name, integratorName(in.options.integrator));
    h5::writeStringAttr(g, K::solver::formulation.name, formulationName(in.formulation));
  }
  {
    auto g = h5::ensureGroup(f, "/damping");
    h5::writeDoubleAttr(g, K::damping::alpha.name, in.options.damping.alpha);
    h5::writeDoubleAttr(g, K::damping::beta.name, in.options.damping.beta);
  }
  for (const auto& [region, v] : in.materials) {  // the model and its parameters by name
    auto g = h5::ensureGroup(f, "/materials/" + region);
    h5::writeStringAttr(g, K::materials::model.name, v.model);
    for (const auto& [name, x] : v.numbers) h5::writeDoubleAttr(g, name, x);
    for (const auto& [name, t] : v.texts) h5::writeStringAttr(g, name, t);
  }
  for (const auto& [group, dirs] : in.fixed) {
    auto g = h5::ensureGroup(f, "/boundary/fixed/" + group);
    h5::writeStringAttr(g, K::boundary_fixed::directions.name, dirs);
  }
  for (const auto& l : in.loads) {
    auto g = h5::ensureGroup(f, "/loads/" + l.name);
    h5::writeStringAttr(g, K::loads::target.name, l.target);
    h5::writeStringAttr(g, K::loads::direction.name, std::string(1, "xyz"[l.direction]));
    h5::writeDoubleAttr(g, K::loads::force.name, l.force);
    h5::writeDoubles(g, K::loads::time.name, l.function.t.data(), {l.function.t.size()});
    h5::writeDoubles(g, K::loads::value.name, l.function.value.data(), {l.function.value.size()});
  }
  if (!in.monitors.empty()) {
    std::vector<std::string> names;
    std::vector<Real> pts;
    for (const auto& m : in.monitors) {
      names.push_back(m.name);
      pts.insert(pts.end(), m.point, m.point + 3);
    }
    h5::writeStrings(h5::ensureGroup(f, "/monitors"), K::monitors::names.name, names);
    h5::writeDoubles(h5::ensureGroup(f, "/monitors"), K::monitors::points.name, pts.data(), {names.size(), 3});
  }
  auto g = h5::ensureGroup(f, "/output");
  h5::writeDoubleAttr(g, K::output::monitor_dt.name, in.monitorDt);
  h5::writeDoubleAttr(g, K::output::progress_s.name, in.progressSeconds);
  if (!in.ringForces) h5::writeIntAttr(g, K::output::ring_forces.name, 0);
  if (in.checkpointInterval > 0) h5::writeDoubleAttr(g, K::output::checkpoint_interval.name, in.checkpointInterval);
  if (!in.snapshotTimes.empty())
    h5::writeDoubles(g, K::output::snapshot_times.name, in.snapshotTimes.data(), {in.snapshotTimes.size()});
  if (in.staged.present) writeStagedGroups(f, in);
}

}  // namespace tq::test
