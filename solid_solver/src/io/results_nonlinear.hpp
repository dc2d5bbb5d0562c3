// results.h5 output of the nonlinear parts (layout in docs/solid_solver.md "Output:
// `results.h5`"): damage, plastic strain and dissipation of Mohr–Coulomb damage elements, and the
// per-pair state of the rock–lining dynamic contact. Private to tqsolid; called by results.cpp.
#pragma once

#include <string>
#include <vector>

#include "h5util.hpp"
#include "tq/contact/contact.hpp"
#include "tq/contact/joints.hpp"
#include "tq/core/solver.hpp"

namespace tq::nlout {

/// What the writer keeps between calls.
struct State {
  std::vector<h5::ClockedRows> monitorDamage;  ///< /monitors/<name>/damage [T, 1], one per monitor
  const DynamicContact* contact = nullptr;     ///< found among the solver's contributors
  h5::ClockedRows interfaceHistory;            ///< /interface/history [T, 7]
  const LiningJoints* joints = nullptr;        ///< the lining's joints, found among the contributors
  h5::ClockedRows jointHistory;                ///< /joints/history [T, 1 + kJointColumns J]
  h5::ClockedRows dissipation;                 ///< /energy/dissipation [T, 3]
  h5::SpaceLedger* ledger = nullptr;           ///< the results file's, for the appenders above
};

/// The rock–lining contact among the solver's contributors, or nullptr.
const DynamicContact* findContact(const Solver& s);

/// The lining's joints among the solver's contributors, or nullptr.
const LiningJoints* findJoints(const Solver& s);

/// Columns of /joints/history per joint, after the time column.
constexpr int kJointColumns = 8;

/// Damage D of element e of block b (0 for a material without damage).
Real elementDamage(const Solver& s, Index block, Index elem);

/// What the first sample() sets up (the interface's header and history, once the contact exists),
/// without a row: a restart appends the rows written before it.
void prepare(hid_t file, const Solver& s, State& st);

/// Create /energy/dissipation [T, 3]: time, plastic (part of `internal`), interface (a balance
/// term of its own: kinetic + internal + damping + boundary + interface − external = const).
void addEnergy(hid_t file, State& st);

/// Create /monitors/<name>/damage for one monitor (call once per monitor, in order).
void addMonitor(hid_t file, const std::string& monitorGroup, State& st);

/// Observe the solver's state: one row per monitor (damage of its element), of /energy/dissipation
/// and of the interface history, kept for write().
void observe(hid_t file, const Solver& s, const std::vector<std::pair<Index, Index>>& monitorElems, State& st);
/// Write the rows at a due time t_k of the output clock (weight w of the last observed state).
void write(double t, double w, State& st);

/// Field snapshot additions under `group`: damage [E], plastic_strain [E, 6], dissipation [E]
/// when a block has a Mohr–Coulomb damage material; interface/{state, opening, slip,
/// normal_force, tangential_force} [P] when the contact exists.
void snapshot(hid_t file, const std::string& group, const Solver& s, State& st);

}  // namespace tq::nlout
