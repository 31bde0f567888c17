// The one place where a scene's coupling scheme becomes the solid's strategy (DESIGN 2,
// STYLE "Swapping a model"): an explicit table, no static self-registration. A new scheme:
// its file in this folder, its factory declared and listed here.
#include <array>
#include <stdexcept>
#include <string>

#include "solid/schemes/solid_scheme.hpp"

namespace cosim::solid {

using SolidSchemeFactory = std::unique_ptr<SolidScheme> (*)(const protocol::SchemeSettings&);

std::unique_ptr<SolidScheme> make_serial_scheme(const protocol::SchemeSettings&);    // serial_scheme.cpp
std::unique_ptr<SolidScheme> make_implicit_scheme(const protocol::SchemeSettings&);  // implicit_scheme.cpp
std::unique_ptr<SolidScheme> make_parallel_scheme(const protocol::SchemeSettings&);  // parallel_scheme.cpp

namespace {

struct SolidSchemeEntry {
  std::string_view name;  ///< as protocol::scheme_name spells it
  SolidSchemeFactory make;
};

// The registry: add a scheme here, and only here.
constexpr std::array kSolidSchemes{
    SolidSchemeEntry{"serial", &make_serial_scheme},
    SolidSchemeEntry{"implicit", &make_implicit_scheme},
    SolidSchemeEntry{"parallel", &make_parallel_scheme},
};

}  // namespace

std::unique_ptr<SolidScheme> make_solid_scheme(const protocol::SchemeSettings& settings) {
  const std::string_view name = protocol::scheme_name(settings.scheme);
  std::string names;
  for (const SolidSchemeEntry& e : kSolidSchemes) {
    if (e.name == name) return e.make(settings);
    names += (names.empty() ? "" : ", ") + std::string(e.name);
  }
  throw std::invalid_argument("no solid side for the coupling scheme \"" + std::string(name) + "\"; available: " + names);
}

}  // namespace cosim::solid
