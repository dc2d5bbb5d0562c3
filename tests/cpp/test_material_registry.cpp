// The material registry (tq/materials/registry.hpp): the models tq-solid builds by name.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "io/input_schema.hpp"
#include "tq/materials/registry.hpp"

using namespace tq;

// Every model the table's `model` row allows is registered, and every registered model is allowed:
// the Python side (solver_input_table.MODELS) and tq-solid name the same models.
TEST(MaterialRegistry, TheTableAndTheRegistryNameTheSameModels) {
  const std::string choices = input_schema::key::materials::model.choices;
  std::vector<std::string> allowed;
  for (size_t a = 0, b; a <= choices.size(); a = b + 1) {
    b = choices.find(',', a);
    if (b == std::string::npos) b = choices.size();
    allowed.push_back(choices.substr(a, b - a));
  }
  for (const auto& name : allowed) EXPECT_NE(findMaterialModel(name), nullptr) << name << " is not registered";
  for (const auto& model : materialModels()) {
    EXPECT_NE(std::find(allowed.begin(), allowed.end(), model.name), allowed.end())
        << model.name << " is not a choice of the table's model row";
  }
  MaterialValues v = elasticValues({8e9, 0.27, 2700});
  v.model = "maxwell";
  try {
    makeMaterial(v);
    FAIL() << "unknown model accepted";
  } catch (const InputError& e) {
    for (const auto& model : materialModels())
      EXPECT_NE(std::string(e.what()).find(model.name), std::string::npos) << e.what();
  }
}
