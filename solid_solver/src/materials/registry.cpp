// The material registry: the one table of the models tq-solid knows. Adding a model: its own
// header and source in materials/ (the class and a factory from MaterialValues), one line here,
// and its rows in scripts/tunnelquake/solver_input_table.py (docs/architecture.md "Add a material").
#include "tq/materials/registry.hpp"

#include <algorithm>

#include "tq/materials/material_kv.hpp"
#include "tq/materials/material_mc.hpp"
#include "tq/materials/material_rc.hpp"

namespace tq {

const std::vector<MaterialModel>& materialModels() {
  static const std::vector<MaterialModel> models = {
      {ElasticMaterial::kName, &makeElasticMaterial},
      {MohrCoulombDamageMaterial::kName, &makeMohrCoulombDamageMaterial},
      {KelvinVoigtMaterial::kName, &makeKelvinVoigtMaterial},
      {ReinforcedConcreteMaterial::kName, &makeReinforcedConcreteMaterial},
  };
  return models;
}

const MaterialModel* findMaterialModel(const std::string& name) {
  const auto& models = materialModels();
  const auto it = std::find_if(models.begin(), models.end(), [&](const MaterialModel& m) { return name == m.name; });
  return it == models.end() ? nullptr : &*it;
}

std::shared_ptr<const Material> makeMaterial(const MaterialValues& v) {
  const MaterialModel* m = findMaterialModel(v.model);
  if (!m) {
    std::string have;
    for (const auto& k : materialModels()) have += std::string(have.empty() ? "" : ", ") + k.name;
    throw InputError("model '" + v.model + "' has no material in this tq-solid (it has: " + have + ")");
  }
  return m->make(v);
}

}  // namespace tq
