// What the water coupling writes into the results file (tq/coupling/coupling_results.hpp).
#include "tq/coupling/coupling_results.hpp"

#include <cstdio>
#include <map>
#include <string>

namespace tq {

void addCouplingSeries(ResultsWriter& results, const Solver& view, const SolidInput& in, FluidCoupling& c,
                       const CarriedWater* water, const std::vector<Index>* nodes,
                       std::function<const std::vector<Real>&()> force) {
  FluidCoupling* cp = &c;
  const std::vector<Index>* wet = nodes ? nodes : &c.nodes();
  if (!force) force = [cp]() -> const std::vector<Real>& { return cp->force(); };
  results.addSeries(
      "/energy/fluid_work", [cp] { return cp->fluidWork(); }, "fluid_work");
  results.addSeries(
      "/energy/fluid_received_work", [cp] { return cp->fluidReceivedWork(); }, "fluid_received_work");
  results.addSeries(
      "/energy/coupling_energy", [cp] { return cp->couplingEnergy(); }, "coupling_energy");
  if (water) {
    results.addSeries(
        "/coupling/volume_pressure", [water] { return water->volumePressure(); }, "volume_pressure");
    // Open ends: the pressure along the axis (each station's, its y an attribute of the group) and a
    // surge tank's level.
    const std::vector<Real>& ys = water->stationPositions();
    std::map<std::string, double> where;
    for (size_t j = 0; j < ys.size(); ++j) {
      char name[32];
      std::snprintf(name, sizeof name, "station_%03zu", j);
      results.addSeries(
          "/coupling/axial_pressure/" + std::string(name), [water, j] { return water->stationPressure(j); },
          "pressure");
      where[std::string(name) + "_y"] = ys[j];
    }
    if (!ys.empty()) results.writeAttrs("/coupling/axial_pressure", where);
    for (int e = 0; e < 2; ++e)
      if (water->hasSurgeTank(e))
        results.addSeries(
            e == 0 ? "/coupling/surge_level_ymin" : "/coupling/surge_level_ymax",
            [water, e] { return water->surgeLevel(e); }, "level");
  }
  results.addWaterPressure(view.mesh(), in.staged.coupling.face, in.monitors, *wet, force);
  // The wetted face as a whole (docs/verification.md, the rigidly shaken lining): the total interface
  // force R3 the coupling added (N) and the mass-weighted mean acceleration a^n of its nodes
  // (m/s²), both of the same step, per direction.
  for (int d = 0; d < 3; ++d) {
    const std::string axis(1, "xyz"[d]);
    results.addSeries(
        "/coupling/force_" + axis,
        [wet, force, d] {
          Real sum = 0;
          const auto& F = force();
          for (size_t k = 0; k < wet->size(); ++k) sum += F[3 * k + size_t(d)];
          return sum;
        },
        "force_" + axis);
    results.addSeries(
        "/coupling/acceleration_" + axis,
        [wet, &st = view.state(), d] {
          Real ma = 0, m = 0;
          for (Index n : *wet) {
            ma += st.mass(n) * st.a(n, d);
            m += st.mass(n);
          }
          return m > 0 ? ma / m : Real(0);
        },
        "acceleration_" + axis);
  }
}

void writeCouplingSummary(ResultsWriter& results, const CouplingInput& in, const FluidCoupling& c,
                          const CarriedWater* water) {
  const FluidCouplingStats cs = c.stats();
  results.writeAttrs("/coupling",
                     {{"windows", double(cs.windows)},
                      {"passes", double(cs.passes)},
                      {"max_passes", double(cs.maxPasses)},
                      {"exchange_s", cs.secondsExchanging},
                      {"unconverged_windows", double(cs.unconvergedWindows)},
                      {"window_size", c.windowSize()},
                      {"fluid_work", c.fluidWork()},
                      {"fluid_received_work", c.fluidReceivedWork()},
                      {"coupling_energy", c.couplingEnergy()},
                      {"volume_law_work", water ? water->work() : 0.0},
                      {"enclosed_volume", water ? water->enclosedVolume() : 0.0},
                      {"interface_work_peak", c.interfaceWorkPeak()},
                      {"energy_floor", c.energyFloor()},
                      {"energy_limit", in.energyLimit},
                      // cost split over the stepping (docs/coupler.md "Exchange cost")
                      {"coupled_wall_s", cs.secondsCoupled},
                      {"solid_s", cs.secondsCoupled - cs.secondsInCoupler},
                      {"solid_first_passes_s", cs.secondsFirstPasses},
                      {"solid_repasses_s", cs.secondsRepasses},
                      {"coupler_s", cs.secondsInCoupler},
                      {"exchange_wait_s", cs.secondsWaiting},
                      {"exchange_work_s", cs.secondsInCoupler - cs.secondsWaiting},
                      {"mapping_s", cs.secondsMapping},
                      {"solid_cpu_s", cs.cpuCoupled - cs.cpuInCoupler},
                      {"coupler_cpu_s", cs.cpuInCoupler}},
                     {{"scheme", in.scheme}});
}

}  // namespace tq
