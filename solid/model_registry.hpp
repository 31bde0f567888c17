// The one place where a scene's solid-model name becomes a model (DESIGN 2.5, STYLE
// "Swapping a model"): an explicit table, no static self-registration.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "solid/solid_config.hpp"
#include "solid/solid_model.hpp"

namespace cosim::solid {

using SolidModelFactory = std::unique_ptr<SolidModel> (*)(const SolidConfig&);

struct SolidModelEntry {
  std::string_view name;
  SolidModelFactory make;
};

/// Every registered model, in the order of the table in model_registry.cpp.
std::span<const SolidModelEntry> solid_models();

/// The registered names joined by ", " (for messages).
std::string available_solid_models();

/// Builds the model registered under `name` from `config`. An unknown name throws
/// std::invalid_argument with one line:
///   unknown solid model "X"; available: rigid, ...
/// The model's constructor may throw std::invalid_argument for a config it cannot take.
std::unique_ptr<SolidModel> make_solid_model(std::string_view name, const SolidConfig& config);

}  // namespace cosim::solid
