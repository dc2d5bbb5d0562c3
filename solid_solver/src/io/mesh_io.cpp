// mesh.h5 reader/writer (layout in docs/formats.md).
#include "h5util.hpp"
#include "tq/io/mesh.hpp"

namespace tq {

Mesh readMeshH5(const std::string& path, const MeshRequirements& req) {
  Mesh m;
  m.source = "'" + path + "'";
  auto f = h5::openFile(path);
  const std::string where = "mesh " + m.source;
  try {
    const std::string fmt = h5::readStringAttr(f, "format");
    if (fmt != "tunnelquake-solid-mesh")
      throw InputError(where + ": attribute format is '" + fmt +
                       "', expected 'tunnelquake-solid-mesh' (is this the water mesh or a results file?)");
    const long long ver = h5::readIntAttr(f, "version");
    if (ver != 1)
      throw InputError(where + ": version " + std::to_string(ver) +
                       " is not supported by this tq-solid (reads version 1); re-run tunnelquake mesh");
    m.slice = h5::hasAttr(f, "slice") && h5::readIntAttr(f, "slice") != 0;

    std::vector<hsize_t> d;
    m.coords = h5::readDoubles(f, "/nodes/coordinates", &d);
    if (d.size() != 2 || d[1] != 3) throw InputError(where + ": /nodes/coordinates must have shape [N, 3]");
    m.connectivity = h5::readInts(f, "/elements/connectivity", &d);
    if (d.size() != 2 || d[1] != 8)
      throw InputError(where + ": /elements/connectivity must have shape [E, 8] (hex8 only)");
    m.region = h5::readInts(f, "/elements/region", &d);
    auto eg = h5::openGroup(f, "/elements");
    m.regionNames = h5::readStringListAttr(eg, "regions");
    if (h5::exists(f, "/faces")) {
      auto fg = h5::openGroup(f, "/faces");
      for (const auto& name : h5::members(fg)) {
        m.faces[name] = h5::readInts(fg, name, &d);
        if (d.size() != 2 || d[1] != 4) throw InputError(where + ": /faces/" + name + " must have shape [F, 4]");
      }
    }
    if (h5::exists(f, "/node_sets")) {
      auto ng = h5::openGroup(f, "/node_sets");
      for (const auto& name : h5::members(ng)) m.nodeSets[name] = h5::readInts(ng, name);
    }
    if (h5::exists(f, "/interfaces/rock_lining")) {
      m.rockLiningPairs = h5::readInts(f, "/interfaces/rock_lining", &d);
      if (d.size() != 2 || d[1] != 2) throw InputError(where + ": /interfaces/rock_lining must have shape [P, 2]");
    }
  } catch (const InputError& e) {
    const std::string msg = e.what();
    if (msg.rfind(where, 0) == 0) throw;
    throw InputError(where + ": " + msg);
  }
  checkMesh(m, req);
  return m;
}

void writeMeshH5(const Mesh& m, const std::string& path) {
  auto f = h5::createFile(path);
  h5::writeStringAttr(f, "format", "tunnelquake-solid-mesh");
  h5::writeIntAttr(f, "version", 1);
  h5::writeIntAttr(f, "slice", m.slice ? 1 : 0);
  const hsize_t N = m.coords.size() / 3, E = m.connectivity.size() / 8;
  h5::writeDoubles(f, "/nodes/coordinates", m.coords.data(), {N, 3});
  h5::writeInts(f, "/elements/connectivity", m.connectivity.data(), {E, 8});
  h5::writeInts(f, "/elements/region", m.region.data(), {E});
  auto eg = h5::openGroup(f, "/elements");
  h5::writeStringListAttr(eg, "regions", m.regionNames);
  for (const auto& [name, q] : m.faces) h5::writeInts(f, "/faces/" + name, q.data(), {q.size() / 4, 4});
  for (const auto& [name, n] : m.nodeSets) h5::writeInts(f, "/node_sets/" + name, n.data(), {n.size()});
  if (!m.rockLiningPairs.empty())
    h5::writeInts(f, "/interfaces/rock_lining", m.rockLiningPairs.data(), {m.rockLiningPairs.size() / 2, 2});
}

}  // namespace tq
