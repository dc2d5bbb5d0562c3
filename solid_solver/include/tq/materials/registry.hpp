/// @file registry.hpp
/// @brief The material models tq-solid knows, by the name solid_input.h5 gives in a region's
///        `model`: one table (src/materials/registry.cpp) of names and factories. A factory makes
///        the model from the region's parameters by name (MaterialValues) and throws InputError on
///        bad values. The reader, the solver's build and `--print-input` ask this table only.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tq/materials/material.hpp"

namespace tq {

/// Makes a model from a region's parameters by name; throws InputError naming a bad parameter.
using MaterialFactory = std::shared_ptr<const Material> (*)(const MaterialValues&);

/// One registered model.
struct MaterialModel {
  const char* name;      ///< the `model` attribute's value (and Material::typeName())
  MaterialFactory make;  ///< builds it from the parameters
};

/// The registered models, in the table's order.
const std::vector<MaterialModel>& materialModels();

/// The registered model named `name`, or nullptr.
const MaterialModel* findMaterialModel(const std::string& name);

/// The material of a region's parameters: its model's factory. Throws InputError when the model is
/// not registered (naming the registered ones) or a parameter is bad.
std::shared_ptr<const Material> makeMaterial(const MaterialValues& v);

}  // namespace tq
