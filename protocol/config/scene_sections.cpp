#include "protocol/config/scene_sections.hpp"

namespace cosim::protocol::config {

const std::vector<SectionOwner>& scene_sections() {
  using enum Owner;
  static const std::vector<SectionOwner> table = {
      // fluid/config/scene_config.cpp
      {"inlet", Fluid},
      {"boundaries", Fluid},
      {"wall_velocity", Fluid},
      {"body_force", Fluid},
      {"held_body", Fluid},
      // The fluid's in a coupled scene (the length of the run); a standalone solid scene has
      // a [run] of its own (solid/config/solid_scene.cpp).
      {"run", Fluid},
      // Both processes. [fluid]'s medium sets the units of both (protocol/units.hpp
      // scene_unit_inputs); the rest of it is the fluid's.
      {"fluid",
       Both,
       false,
       {{"tau", Fluid},
        {"reynolds", Fluid},
        {"reference_length_um", Fluid},
        {"viscosity_m2_s", Fluid},
        {"density_kg_m3", Both},
        {"sound_speed_m_s", Both}}},
      {"scene", Both, false, {{"name", Both}, {"description", Both}}},
      {"grid", Both, false, {{"nx", Fluid}, {"ny", Fluid}, {"nz", Fluid}, {"dx_um", Both}}},
      {"output",
       Both,
       false,
       {{"directory", Both},
        {"fields_every", Fluid},
        {"planes_every", Fluid},
        {"planes_y", Fluid},
        {"sheets_every", Solid}}},
      {"coupling", Both},
      {"watchdog", Both},
      // solid/config/solid_scene.cpp and the models' options (solid/model/model_registry.cpp).
      {"solid", Solid},
      {"sheet", Solid, true},
      {"contact", Solid},
      {"material", Solid},
      {"perturbation", Solid},
      {"load", Solid},
      // protocol/config/reaction_section.cpp (the law of solid/coupling/reaction_law.hpp).
      {"reaction", Solid},
  };
  return table;
}

const SectionOwner* find_section_owner(std::string_view name) {
  for (const SectionOwner& s : scene_sections())
    if (s.name == name) return &s;
  return nullptr;
}

}  // namespace cosim::protocol::config
