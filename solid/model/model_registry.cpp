#include "solid/model/model_registry.hpp"

#include <array>
#include <stdexcept>

#include "solid/models/elastic_sheet/elastic_sheet_model.hpp"
#include "solid/models/elastic_sheet/elastic_sheet_options.hpp"
#include "solid/models/rigid/rigid_model.hpp"
#include "solid/models/sprung/sprung_model.hpp"

namespace cosim::solid {

namespace {

template <class Model>
std::unique_ptr<SolidModel> make(const SolidConfig& config) {
  return std::make_unique<Model>(config);
}

std::unique_ptr<SolidModel> make_rcgp(const SolidConfig& config) {
  return std::make_unique<ElasticSheetModel>(config, SheetKinematics::Linear);
}

std::unique_ptr<SolidModel> make_corotational(const SolidConfig& config) {
  return std::make_unique<ElasticSheetModel>(config, SheetKinematics::Corotational);
}

constexpr std::array kElasticSheetOptions{&kRcgpOptions, &kContactOptions, &kBodyForceOptions,
                                          &kMaterialOptions};

constexpr std::array kSprungOptions{&kSpringOptions};

// The registry: add a model here, and only here (name, factory, the options it reads).
constexpr std::array kSolidModels{
    SolidModelEntry{ElasticSheetModel::kRcgpName, &make_rcgp, kElasticSheetOptions},
    SolidModelEntry{RigidModel::kName, &make<RigidModel>},
    SolidModelEntry{ElasticSheetModel::kCorotationalName, &make_corotational, kElasticSheetOptions},
    SolidModelEntry{SprungModel::kName, &make<SprungModel>, kSprungOptions},
};

}  // namespace

std::span<const SolidModelEntry> solid_models() { return kSolidModels; }

std::string available_solid_models() {
  std::string names;
  for (const SolidModelEntry& e : kSolidModels) {
    if (!names.empty()) names += ", ";
    names += e.name;
  }
  return names;
}

std::unique_ptr<SolidModel> make_solid_model(std::string_view name, const SolidConfig& config) {
  for (const SolidModelEntry& e : kSolidModels)
    if (e.name == name) return e.make(config);
  throw std::invalid_argument("unknown solid model \"" + std::string(name) +
                              "\"; available: " + available_solid_models());
}

}  // namespace cosim::solid
