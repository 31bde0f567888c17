// The units of every dataset the servers write (monitor.h5, solid.h5, the field, plane and
// sheet snapshots), by dataset name: the one table behind the "units" attribute that
// stamp_units() (common/run/provenance_h5.hpp) puts on each dataset.
#pragma once

#include <optional>
#include <string>

namespace cosim::protocol {

/// The units of the dataset `name` (its last path component): from its suffix (_um, _m_s,
/// _N, _J, _s, _us) or the table of the other names; nothing for a name the table does
/// not know (OutputsCarryProvenance fails on such a dataset).
std::optional<std::string> dataset_units(const std::string& name);

}  // namespace cosim::protocol
