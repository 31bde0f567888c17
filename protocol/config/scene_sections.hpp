// The one table of which process owns which section of a scene file (DESIGN 2: "one table of
// which process owns which section"). A coupled scene is one file read by both processes:
// each reads the sections it owns and the shared ones, leaves the other's unread, and refuses
// everything that is no one's, with a did-you-mean (protocol/config/scene_reader.hpp).
//
// A section a solid model brings of its own is a row here with Owner::Solid (the fluid's
// parser needs no change: it skips the solid's sections of a coupled scene and refuses them
// in a fluid-only one); its keys are the solid's business (solid/model/model_registry.cpp).
#pragma once

#include <string_view>
#include <vector>

namespace cosim::protocol::config {

/// The process that reads a scene file.
enum class Process { Fluid, Solid };

/// Who reads a section, or a key of a shared section.
enum class Owner { Fluid, Solid, Both };

struct KeyOwner {
  std::string_view key;
  Owner owner;
};

struct SectionOwner {
  std::string_view name;
  Owner owner;
  bool array = false;  ///< an array of tables ([[name]])
  /// Of a shared section (Owner::Both): every key and who reads it. Empty for a section
  /// with one owner (its keys are that process's schema) and for [coupling] and [watchdog],
  /// which protocol/config/coupling_config.hpp reads for both.
  std::vector<KeyOwner> keys = {};
};

/// Every section a scene file may have, fluid's first, then the shared ones, then the
/// solid's.
const std::vector<SectionOwner>& scene_sections();

/// The row of `name`, or null if no process reads such a section.
const SectionOwner* find_section_owner(std::string_view name);

/// Whether `owner` is read by process `p`.
constexpr bool reads(Process p, Owner owner) {
  return owner == Owner::Both || (owner == Owner::Fluid) == (p == Process::Fluid);
}

/// "fluid" or "solid".
constexpr const char* process_name(Process p) { return p == Process::Fluid ? "fluid" : "solid"; }

}  // namespace cosim::protocol::config
