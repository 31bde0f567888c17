#include "common/hdf5/xdmf.hpp"

#include <iomanip>
#include <sstream>

#include "common/run/atomic_file.hpp"

namespace cosim::protocol::xdmf {

namespace {

void put_item(std::ostringstream& x, const DataItem& d) {
  x << "          <DataItem Format=\"" << d.format << "\" NumberType=\"" << d.number_type << "\" Precision=\""
    << d.precision << "\" Dimensions=\"" << d.dimensions << "\">" << d.text << "</DataItem>\n";
}

}  // namespace

DataItem hdf(const std::string& file, const std::string& dataset, const std::string& number_type, int precision,
             const std::string& dimensions) {
  return {"HDF", number_type, precision, dimensions, file + ":/" + dataset};
}

DataItem xml(const std::vector<double>& values) {
  std::ostringstream t;
  t << std::setprecision(12);
  for (std::size_t i = 0; i < values.size(); ++i) t << (i == 0 ? "" : " ") << values[i];
  return {"XML", "Float", 8, std::to_string(values.size()), t.str()};
}

std::string temporal_collection(const std::string& name, const std::vector<Grid>& grids) {
  std::ostringstream x;
  x << std::setprecision(12);
  x << "<?xml version=\"1.0\" ?>\n"
    << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
    << "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
    << "  <Domain>\n"
    << "    <Grid Name=\"" << name << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const Grid& g : grids) {
    x << "      <Grid Name=\"" << g.name << "\" GridType=\"Uniform\">\n"
      << "        <Time Value=\"" << g.time << "\"/>\n"
      << "        <Topology TopologyType=\"" << g.topology.type << "\"";
    for (const auto& [key, value] : g.topology.properties) x << ' ' << key << "=\"" << value << '"';
    if (g.topology.items.empty()) {
      x << "/>\n";
    } else {
      x << ">\n";
      for (const DataItem& d : g.topology.items) put_item(x, d);
      x << "        </Topology>\n";
    }
    x << "        <Geometry GeometryType=\"" << g.geometry.type << "\">\n";
    for (const DataItem& d : g.geometry.items) put_item(x, d);
    x << "        </Geometry>\n";
    for (const Attribute& a : g.attributes) {
      x << "        <Attribute Name=\"" << a.name << "\" AttributeType=\"" << a.type << "\" Center=\"Node\">\n";
      put_item(x, a.item);
      x << "        </Attribute>\n";
    }
    x << "      </Grid>\n";
  }
  x << "    </Grid>\n"
    << "  </Domain>\n"
    << "</Xdmf>\n";
  return x.str();
}

void write_temporal_collection(const std::filesystem::path& file, const std::string& name,
                               const std::vector<Grid>& grids) {
  write_text_atomically(file, temporal_collection(name, grids));
}

}  // namespace cosim::protocol::xdmf
