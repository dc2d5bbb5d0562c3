// Python bindings of the coupler (module `_coupler`, loaded by the package tunnelquake.coupling
// from the build folder): the configuration, a participant over TCP or MPI, the MPI start-up of
// an MPMD job, the analytic ring scenario of the fake participants and the convergence measure.
// Every C++ CouplerError becomes the Python exception of the same name (TimeoutError as
// CouplingTimeoutError); ProtocolError carries its fault name in `.fault`.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "ring_scenario.hpp"
#include "tq/coupler/participant.hpp"
#include "tq/coupler/scheme.hpp"

namespace py = pybind11;
using namespace tq::coupler;

namespace {

using F64Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using I64Array = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;
using I32Array = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>;

template <class T>
std::vector<T> toVector(const py::array_t<T, py::array::c_style | py::array::forcecast>& a) {
  return std::vector<T>(a.data(), a.data() + a.size());
}

/// values[rows, cols] as a new NumPy array.
py::array_t<double> toArray(const std::vector<double>& v, std::size_t cols) {
  py::array_t<double> out({v.size() / cols, cols});
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

const char* constraintName(MapConstraint c) { return c == MapConstraint::Consistent ? "consistent" : "conservative"; }
MapConstraint parseConstraint(const std::string& s) {
  if (s == "consistent") return MapConstraint::Consistent;
  if (s == "conservative") return MapConstraint::Conservative;
  throw ConfigError("unknown map constraint '" + s + "' (consistent, conservative)");
}

/// A Participant with NumPy arrays: readData returns [nodes, components].
class PyParticipant {
 public:
  PyParticipant(const std::string& name, const CouplingConfig& config, const std::string& token,
                const std::string& transport, const std::string& addressFile, std::optional<bool> listen,
                const std::string& bind, const std::string& connectHost, int connectPort, double connectTimeout,
                double receiveTimeout) {
    TransportOptions t;
    if (transport == "tcp")
      t.kind = TransportKind::Tcp;
    else if (transport == "mpi")
      t.kind = TransportKind::Mpi;
    else
      throw ConfigError("participant '" + name + "': unknown transport '" + transport + "' (tcp, mpi)");
    t.role = !listen ? ConnectRole::Auto : *listen ? ConnectRole::Listen : ConnectRole::Connect;
    t.addressFile = addressFile;
    t.bindAddress = bind;
    t.connectHost = connectHost;
    t.connectPort = connectPort;
    t.connectTimeout = connectTimeout;
    t.receiveTimeout = receiveTimeout;
    p_ = std::make_unique<Participant>(name, config, t, token);
  }

  void setMeshVertices(const std::string& mesh, const I64Array& ids, const F64Array& xyz,
                       const std::optional<I32Array>& triangles) {
    p_->setMeshVertices(mesh, toVector(ids), toVector(xyz),
                        triangles ? toVector(*triangles) : std::vector<std::int32_t>{});
  }

  void writeData(const std::string& mesh, const std::string& field, const F64Array& v) {
    p_->writeData(mesh, field, v.data(), std::size_t(v.size()));
  }

  py::array_t<double> readData(const std::string& mesh, const std::string& field) const {
    std::vector<double> v;
    p_->readData(mesh, field, v);
    const int i = p_->config().fieldIndex(mesh, field);
    return toArray(v, std::size_t(p_->config().fields.at(std::size_t(i)).components));
  }

  py::bytes saveState() const {
    const auto s = p_->saveState();
    return py::bytes(reinterpret_cast<const char*>(s.data()), s.size());
  }

  double initializeResumed(const std::string& state) {
    const std::vector<unsigned char> s(state.begin(), state.end());
    py::gil_scoped_release release;
    return p_->initializeResumed(s);
  }

  Participant& p() { return *p_; }
  const Participant& p() const { return *p_; }

 private:
  std::unique_ptr<Participant> p_;
};

/// θ of solid node k of the ring (for the nodes of either side).
py::array_t<double> ringTheta(const scenario::Ring& r, const I64Array& k) {
  py::array_t<double> out(k.size());
  for (py::ssize_t i = 0; i < k.size(); ++i) out.mutable_data()[i] = r.theta(int(k.data()[i]));
  return out;
}

// The module's exception classes (owned by the module; kept for the translator).
py::handle gCoupler, gConfig, gProtocol, gHandshake, gTransport, gTimeout, gLost, gMap, gDivergence;

py::handle newError(py::module_& m, const char* name, py::handle base) {
  return py::exception<CouplerError>(m, name, base).release();
}

/// Translates the coupler's exceptions (most derived first).
void registerErrors(py::module_& m) {
  gCoupler = newError(m, "CouplerError", PyExc_RuntimeError);
  gConfig = newError(m, "ConfigError", gCoupler);
  gProtocol = newError(m, "ProtocolError", gCoupler);
  gHandshake = newError(m, "HandshakeError", gCoupler);
  gTransport = newError(m, "TransportError", gCoupler);
  gTimeout = newError(m, "CouplingTimeoutError", gTransport);
  gLost = newError(m, "PartnerLostError", gTransport);
  gMap = newError(m, "MapError", gCoupler);
  gDivergence = newError(m, "DivergenceError", gCoupler);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const ProtocolError& e) {
      py::object err = py::reinterpret_borrow<py::object>(gProtocol)(e.what());
      err.attr("fault") = faultName(e.fault());
      PyErr_SetObject(gProtocol.ptr(), err.ptr());
    } catch (const TimeoutError& e) {
      PyErr_SetString(gTimeout.ptr(), e.what());
    } catch (const PartnerLostError& e) {
      PyErr_SetString(gLost.ptr(), e.what());
    } catch (const TransportError& e) {
      PyErr_SetString(gTransport.ptr(), e.what());
    } catch (const ConfigError& e) {
      PyErr_SetString(gConfig.ptr(), e.what());
    } catch (const HandshakeError& e) {
      PyErr_SetString(gHandshake.ptr(), e.what());
    } catch (const MapError& e) {
      PyErr_SetString(gMap.ptr(), e.what());
    } catch (const DivergenceError& e) {
      PyErr_SetString(gDivergence.ptr(), e.what());
    } catch (const CouplerError& e) {
      PyErr_SetString(gCoupler.ptr(), e.what());
    }
  });
}

}  // namespace

PYBIND11_MODULE(_coupler, m) {
  m.doc() = "The TunnelQuake coupler (C++ library tqcoupler): see docs/coupler.md";
  registerErrors(m);

  py::class_<MeshSpec>(m, "MeshSpec")
      .def(py::init([](std::string name, const std::string& mapping, std::string mappingSide, double tolerance) {
             return MeshSpec{std::move(name), parseMapKind(mapping), std::move(mappingSide), tolerance};
           }),
           py::arg("name"), py::arg("mapping") = "coincident", py::arg("mapping_side") = "",
           py::arg("tolerance") = 1e-6)
      .def_readwrite("name", &MeshSpec::name)
      .def_property(
          "mapping", [](const MeshSpec& s) { return std::string(mapKindName(s.mapping)); },
          [](MeshSpec& s, const std::string& v) { s.mapping = parseMapKind(v); })
      .def_readwrite("mapping_side", &MeshSpec::mappingSide)
      .def_readwrite("tolerance", &MeshSpec::tolerance);

  py::class_<FieldSpec>(m, "FieldSpec")
      .def(py::init([](std::string mesh, std::string name, int components, std::string writer,
                       const std::string& constraint, double absoluteTolerance) {
             return FieldSpec{
                 std::move(mesh),  std::move(name), components, std::move(writer), parseConstraint(constraint),
                 absoluteTolerance};
           }),
           py::arg("mesh"), py::arg("name"), py::arg("components") = 3, py::arg("writer"),
           py::arg("constraint") = "consistent", py::arg("absolute_tolerance") = 0.0)
      .def_readwrite("mesh", &FieldSpec::mesh)
      .def_readwrite("name", &FieldSpec::name)
      .def_readwrite("components", &FieldSpec::components)
      .def_readwrite("writer", &FieldSpec::writer)
      .def_property(
          "constraint", [](const FieldSpec& s) { return std::string(constraintName(s.constraint)); },
          [](FieldSpec& s, const std::string& v) { s.constraint = parseConstraint(v); })
      .def_readwrite("absolute_tolerance", &FieldSpec::absoluteTolerance);

  py::class_<CouplingConfig>(m, "CouplingConfig")
      .def(py::init([](std::string first, std::string second, double windowSize, std::uint64_t maxWindows,
                       const std::string& scheme, int maxIterations, double tolerance, const std::string& acceleration,
                       double initialRelaxation, const std::string& predictor, int reuse, std::vector<MeshSpec> meshes,
                       std::vector<FieldSpec> fields) {
             CouplingConfig c;
             c.first = std::move(first);
             c.second = std::move(second);
             c.windowSize = windowSize;
             c.maxWindows = maxWindows;
             c.scheme = parseScheme(scheme);
             c.maxIterations = maxIterations;
             c.tolerance = tolerance;
             c.acceleration = parseAcceleration(acceleration);
             c.initialRelaxation = initialRelaxation;
             c.predictor = parsePredictor(predictor);
             c.reuse = reuse;
             c.meshes = std::move(meshes);
             c.fields = std::move(fields);
             return c;
           }),
           py::kw_only(), py::arg("first"), py::arg("second"), py::arg("window_size"), py::arg("max_windows"),
           py::arg("scheme") = "implicit", py::arg("max_iterations") = 20, py::arg("tolerance") = 1e-4,
           py::arg("acceleration") = "aitken", py::arg("initial_relaxation") = 0.5, py::arg("predictor") = "constant",
           py::arg("reuse") = 0, py::arg("meshes"), py::arg("fields"))
      .def_readwrite("first", &CouplingConfig::first)
      .def_readwrite("second", &CouplingConfig::second)
      .def_readwrite("window_size", &CouplingConfig::windowSize)
      .def_readwrite("max_windows", &CouplingConfig::maxWindows)
      .def_property(
          "scheme", [](const CouplingConfig& c) { return std::string(schemeName(c.scheme)); },
          [](CouplingConfig& c, const std::string& v) { c.scheme = parseScheme(v); })
      .def_readwrite("max_iterations", &CouplingConfig::maxIterations)
      .def_readwrite("tolerance", &CouplingConfig::tolerance)
      .def_property(
          "acceleration", [](const CouplingConfig& c) { return std::string(accelerationName(c.acceleration)); },
          [](CouplingConfig& c, const std::string& v) { c.acceleration = parseAcceleration(v); })
      .def_readwrite("initial_relaxation", &CouplingConfig::initialRelaxation)
      .def_property(
          "predictor", [](const CouplingConfig& c) { return std::string(predictorName(c.predictor)); },
          [](CouplingConfig& c, const std::string& v) { c.predictor = parsePredictor(v); })
      .def_readwrite("reuse", &CouplingConfig::reuse)
      .def_readwrite("meshes", &CouplingConfig::meshes)
      .def_readwrite("fields", &CouplingConfig::fields)
      .def("validate", &CouplingConfig::validate);

  py::class_<SchemeState>(m, "SchemeState")
      .def_readonly("window", &SchemeState::window)
      .def_readonly("iteration", &SchemeState::iteration)
      .def_readonly("ongoing", &SchemeState::ongoing)
      .def_readonly("window_complete", &SchemeState::windowComplete)
      .def_readonly("residual", &SchemeState::residual)
      .def_readonly("total_iterations", &SchemeState::totalIterations)
      .def_readonly("unconverged_windows", &SchemeState::unconvergedWindows);

  using Release = py::call_guard<py::gil_scoped_release>;
  py::class_<PyParticipant>(m, "Participant")
      .def(py::init<const std::string&, const CouplingConfig&, const std::string&, const std::string&,
                    const std::string&, std::optional<bool>, const std::string&, const std::string&, int, double,
                    double>(),
           py::arg("name"), py::arg("config"), py::arg("token"), py::kw_only(), py::arg("transport") = "tcp",
           py::arg("address_file") = "", py::arg("listen") = py::none(), py::arg("bind") = "127.0.0.1",
           py::arg("connect_host") = "127.0.0.1", py::arg("connect_port") = 0, py::arg("connect_timeout") = 120.0,
           py::arg("receive_timeout") = 120.0,
           "A coupling participant; `listen` None: the configuration's first participant listens.")
      .def("set_mesh_vertices", &PyParticipant::setMeshVertices, py::arg("mesh"), py::arg("ids"),
           py::arg("coordinates"), py::arg("triangles") = py::none())
      .def(
          "initialize", [](PyParticipant& s) { return s.p().initialize(); }, Release())
      .def("initialize_resumed", &PyParticipant::initializeResumed, py::arg("state"))
      .def("save_state", &PyParticipant::saveState)
      .def("write_data", &PyParticipant::writeData, py::arg("mesh"), py::arg("field"), py::arg("values"))
      .def("read_data", &PyParticipant::readData, py::arg("mesh"), py::arg("field"))
      .def(
          "advance", [](PyParticipant& s, double dt) { return s.p().advance(dt); }, py::arg("dt"), Release())
      .def("is_coupling_ongoing", [](const PyParticipant& s) { return s.p().isCouplingOngoing(); })
      .def("is_time_window_complete", [](const PyParticipant& s) { return s.p().isTimeWindowComplete(); })
      .def("requires_writing_checkpoint", [](const PyParticipant& s) { return s.p().requiresWritingCheckpoint(); })
      .def("requires_reading_checkpoint", [](const PyParticipant& s) { return s.p().requiresReadingCheckpoint(); })
      .def("get_max_time_step_size", [](const PyParticipant& s) { return s.p().getMaxTimeStepSize(); })
      .def(
          "finalize", [](PyParticipant& s) { s.p().finalize(); }, Release())
      .def(
          "abort", [](PyParticipant& s, const std::string& reason) { s.p().abort(reason); }, py::arg("reason"),
          Release())
      .def_property_readonly("name", [](const PyParticipant& s) { return s.p().name(); })
      .def_property_readonly("partner", [](const PyParticipant& s) { return s.p().partner(); })
      .def_property_readonly("config", [](const PyParticipant& s) { return s.p().config(); })
      .def_property_readonly("state", [](const PyParticipant& s) { return s.p().state(); })
      .def_property_readonly("window_start_time", [](const PyParticipant& s) { return s.p().windowStartTime(); })
      .def("partner_vertex_count",
           [](const PyParticipant& s, const std::string& mesh) { return s.p().partnerVertexCount(mesh); })
      .def(
          "partner_part_nodes",
          [](const PyParticipant& s, const std::string& mesh) { return s.p().partnerPartNodes(mesh); }, py::arg("mesh"),
          "The nodes each of the partner's parts exchanges (one count: a partner in one piece).")
      .def("stats", [](const PyParticipant& s) {
        const ExchangeStats x = s.p().stats();
        py::dict d;
        d["exchanges"] = x.exchanges;
        d["seconds_in_transport"] = x.secondsInTransport;
        d["seconds_waiting"] = x.secondsWaiting;
        d["seconds_mapping"] = x.secondsMapping;
        d["bytes_sent"] = x.bytesSent;
        d["bytes_received"] = x.bytesReceived;
        return d;
      });

  m.def("have_mpi", &haveMpi, "True when the coupler was built with MPI");
  m.def(
      "mpi_initialize", [] { mpi::initialize(nullptr, nullptr); },
      "MPI_Init (thread level funneled) unless MPI is initialized already");
  m.def("mpi_split_world", &mpi::splitWorld, py::arg("participant"), py::arg("partner"),
        "MPMD start-up: every process of both applications calls it once (collective); returns "
        "the Fortran handle of this application's communicator");
  m.def("mpi_finalize", &mpi::finalize, "MPI_Finalize if this module initialized MPI");

  m.def(
      "convergence_measure",
      [](const F64Array& a, const F64Array& b, const std::vector<std::tuple<std::size_t, std::size_t, double>>& slices,
         double tolerance) {
        std::vector<FieldSlice> s;
        for (const auto& [offset, size, floor] : slices) s.push_back({"", offset, size, floor});
        return convergenceMeasure(toVector(a), toVector(b), s, tolerance);
      },
      py::arg("a"), py::arg("b"), py::arg("slices"), py::arg("tolerance"),
      "One pass's convergence measure; slices: (offset, size, absolute tolerance) per field");

  py::class_<scenario::Ring>(m, "RingScenario", "The analytic ring of the fake participants (ring_scenario.hpp)")
      .def(py::init([](int nTheta, int nLayers, double radius, double length) {
             return scenario::Ring{nTheta, nLayers, radius, length};
           }),
           py::arg("n_theta") = 64, py::arg("n_layers") = 2, py::arg("radius") = 4.5, py::arg("length") = 1.0)
      .def_readonly("n_theta", &scenario::Ring::nTheta)
      .def_readonly("n_layers", &scenario::Ring::nLayers)
      .def_readonly("radius", &scenario::Ring::radius)
      .def_readonly("length", &scenario::Ring::length)
      .def_property_readonly("nodes", &scenario::Ring::nodes)
      .def("theta", &ringTheta, py::arg("k"), "θ of solid node(s) k")
      .def("solid_ids",
           [](const scenario::Ring& r) {
             const auto v = r.solidIds();
             return py::array_t<std::int64_t>(v.size(), v.data());
           })
      .def("solid_coordinates", [](const scenario::Ring& r) { return toArray(r.solidCoordinates(), 3); })
      .def("solid_triangles",
           [](const scenario::Ring& r) {
             const auto t = r.solidTriangles();
             return py::array_t<std::int32_t>({t.size() / 3, std::size_t(3)}, t.data());
           })
      .def("fluid_ids",
           [](const scenario::Ring& r) {
             const auto v = r.fluidIds();
             return py::array_t<std::int64_t>(v.size(), v.data());
           })
      .def("fluid_coordinates", [](const scenario::Ring& r) { return toArray(r.fluidCoordinates(), 3); })
      .def("fluid_triangles",
           [](const scenario::Ring& r) {
             const auto t = r.fluidTriangles();
             return py::array_t<std::int32_t>({t.size() / 3, std::size_t(3)}, t.data());
           })
      .def(
          "velocity",
          [](const scenario::Ring& r, double t, bool onSolid) {
            return toArray(scenario::field(r, onSolid, true, t), 3);
          },
          py::arg("t"), py::arg("on_solid") = true, "prescribed wall velocity (m/s) at time t")
      .def(
          "force",
          [](const scenario::Ring& r, double t, bool onSolid) {
            return toArray(scenario::field(r, onSolid, false, t), 3);
          },
          py::arg("t"), py::arg("on_solid") = false, "prescribed force (N per node) at time t");
}
