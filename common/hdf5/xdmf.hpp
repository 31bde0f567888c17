// The one XDMF 3 writer of the project: a temporal collection of uniform grids whose data
// are datasets of HDF5 files beside it, the index ParaView opens. Its callers describe
// their grids: the fluid's 3DCoRectMesh (fluid/io/field_writer.cpp: fields.xmf, the
// planes' PREFIX.xmf) and the solid's quadrilaterals over a point cloud
// (solid/io/sheet_snapshots.cpp: sheets.xmf). Numbers are written with 12 significant
// digits.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace cosim::protocol::xdmf {

/// One <DataItem>: values in the XML itself (Format "XML") or a dataset of an HDF5 file
/// (Format "HDF", text "FILE:/DATASET").
struct DataItem {
  std::string format;       ///< "HDF" or "XML"
  std::string number_type;  ///< "Float", "Int"
  int precision = 8;        ///< bytes a value
  std::string dimensions;   ///< "nz ny nx", "n 3"
  std::string text;
};

/// Dataset `dataset` of the HDF5 file `file` (named relative to the XDMF file).
DataItem hdf(const std::string& file, const std::string& dataset, const std::string& number_type, int precision,
             const std::string& dimensions);
/// Float64 values written in the XML.
DataItem xml(const std::vector<double>& values);

/// <Topology TopologyType="TYPE" KEY="VALUE"...> with its data items (none: an empty element).
struct Topology {
  std::string type;
  std::vector<std::pair<std::string, std::string>> properties;  ///< e.g. {"Dimensions", "nz ny nx"}
  std::vector<DataItem> items;
};

/// <Geometry GeometryType="TYPE"> with its data items.
struct Geometry {
  std::string type;
  std::vector<DataItem> items;
};

/// <Attribute Name="NAME" AttributeType="TYPE" Center="Node"> with its one data item.
struct Attribute {
  std::string name;
  std::string type;  ///< "Scalar", "Vector"
  DataItem item;
};

/// One uniform grid of the collection: one time.
struct Grid {
  std::string name;
  double time = 0;
  Topology topology;
  Geometry geometry;
  std::vector<Attribute> attributes;
};

/// The XDMF text of the temporal collection `name` of `grids` (in their order).
std::string temporal_collection(const std::string& name, const std::vector<Grid>& grids);

/// Writes it to `file`, whole or not at all (write_text_atomically).
void write_temporal_collection(const std::filesystem::path& file, const std::string& name,
                               const std::vector<Grid>& grids);

}  // namespace cosim::protocol::xdmf
