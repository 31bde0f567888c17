// The one place where a scene's solid-model name becomes a model (DESIGN 2.5, STYLE
// "Swapping a model"): an explicit table, no static self-registration. Each model names the
// options it reads (groups of keys parsed beside the model, e.g.
// solid/models/elastic_sheet/elastic_sheet_options.cpp); solid/config/solid_scene.cpp validates every group's keys and
// refuses those the chosen model does not read. A new model is its file (with its options,
// if any) and a line in model_registry.cpp.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "solid/model/solid_config.hpp"
#include "solid/model/solid_model.hpp"

namespace cosim::protocol::config {
class Table;
}

namespace cosim::solid {

using SolidModelFactory = std::unique_ptr<SolidModel> (*)(const SolidConfig&);

/// Options a model reads: keys of one section of the scene ([solid], [contact], or a section
/// of the model's own, which then needs a row in protocol/config/scene_sections.cpp), read
/// into the model's part of SolidConfig with one-line errors.
struct ModelOptions {
  std::string_view section;
  std::span<const std::string_view> keys;
  /// Validates the keys present in `section` (absent: not present()) into `config`.
  void (*read)(const protocol::config::Table& section, SolidConfig& config);
};

struct SolidModelEntry {
  std::string_view name;
  SolidModelFactory make;
  std::span<const ModelOptions* const> options = {};  ///< none: the model reads no options
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
