// tq-coupler-dummy: a fake participant that drives the coupling API alone (a "solver dummy").
//
// It plays the solid (writes the prescribed wall velocity of ring_scenario.hpp, reads the
// force) or the fluid (writes the prescribed force, reads the velocity), checks that every
// value it reads equals the partner's prescription, and reports. Used by the MPI tests
// (ctest coupler.mpi.*), and to debug a real solver against a fake partner.
//
//   tq-coupler-dummy --role solid --token T --address-file run/wall.addr --windows 20
//   tq-coupler-dummy --role fluid --token T --address-file run/wall.addr --windows 20
//
// Exit codes: 0 success; 2 a coupler error (typed message on stderr); 3 received data differ
// from the prescription; 4 bad command line.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <thread>

#include "ring_scenario.hpp"
#include "tq/coupler/participant.hpp"

using namespace tq::coupler;

namespace {

const char* kUsage = R"(usage: tq-coupler-dummy --role solid|fluid --token TOKEN [options]
  --transport tcp|mpi        (tcp)
  --address-file FILE        listener publishes / connector reads the TCP address here
  --port P                   connector: partner's port instead of an address file
  --listen | --connect       override the default (the solid listens)
  --bind ADDR                listener address (127.0.0.1)
  --scheme explicit|paper|implicit (implicit)  --acceleration none|constant|aitken|iqn-ils
  --windows N (10)  --window-size S (0.001)  --max-iterations K (20)  --tolerance X (1e-8)
  --n-theta N (64)  --n-layers N (2)  --map coincident|projection (coincident)
  --timeout S (10)  --connect-timeout S (10)
  --die-at-window W          exit abruptly (no goodbye) when window W starts: a killed solver
  --hang-at-window W         stop answering when window W starts: a hung solver
  --report FILE              write "key value" lines: windows, passes, max_error, error_kind, ...
)";

std::string errorKind(const std::exception& e) {
  if (dynamic_cast<const TimeoutError*>(&e)) return "TimeoutError";
  if (dynamic_cast<const PartnerLostError*>(&e)) return "PartnerLostError";
  if (dynamic_cast<const TransportError*>(&e)) return "TransportError";
  if (dynamic_cast<const HandshakeError*>(&e)) return "HandshakeError";
  if (dynamic_cast<const ProtocolError*>(&e)) return "ProtocolError";
  if (dynamic_cast<const MapError*>(&e)) return "MapError";
  if (dynamic_cast<const DivergenceError*>(&e)) return "DivergenceError";
  if (dynamic_cast<const ConfigError*>(&e)) return "ConfigError";
  return "Error";
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> opt{{"transport", "tcp"},  {"scheme", "implicit"},   {"acceleration", "aitken"},
                                         {"windows", "10"},     {"window-size", "0.001"}, {"max-iterations", "20"},
                                         {"tolerance", "1e-8"}, {"n-theta", "64"},        {"n-layers", "2"},
                                         {"map", "coincident"}, {"timeout", "10"},        {"connect-timeout", "10"},
                                         {"bind", "127.0.0.1"}, {"die-at-window", "-1"},  {"hang-at-window", "-1"}};
  bool listen = false, connect = false;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--listen") {
      listen = true;
      continue;
    }
    if (a == "--connect") {
      connect = true;
      continue;
    }
    if (a == "-h" || a == "--help") {
      std::cout << kUsage;
      return 0;
    }
    if (a.rfind("--", 0) != 0 || i + 1 >= argc) {
      std::cerr << "tq-coupler-dummy: bad argument '" << a << "'\n" << kUsage;
      return 4;
    }
    opt[a.substr(2)] = argv[++i];
  }
  const std::string role = opt["role"];
  if ((role != "solid" && role != "fluid") || opt["token"].empty()) {
    std::cerr << "tq-coupler-dummy: --role solid|fluid and --token are required\n" << kUsage;
    return 4;
  }
  const bool isSolid = role == "solid";
  const std::string report = opt["report"];
  std::map<std::string, std::string> out;
  auto writeReport = [&] {
    if (report.empty()) return;
    std::ofstream f(report);
    for (const auto& [k, v] : out) f << k << " " << v << "\n";
  };
  const bool mpi = opt["transport"] == "mpi";
  int rc = 0;
  try {
    scenario::Ring ring;
    ring.nTheta = std::stoi(opt["n-theta"]);
    ring.nLayers = std::stoi(opt["n-layers"]);

    CouplingConfig c;
    c.first = "solid";
    c.second = "fluid";
    c.scheme = parseScheme(opt["scheme"]);
    c.acceleration = parseAcceleration(opt["acceleration"]);
    c.windowSize = std::stod(opt["window-size"]);
    c.maxWindows = std::stoull(opt["windows"]);
    c.maxIterations = std::stoi(opt["max-iterations"]);
    c.tolerance = std::stod(opt["tolerance"]);
    c.meshes.push_back({"wall", parseMapKind(opt["map"]), "solid", 1e-6});
    c.fields.push_back({"wall", "velocity", 3, "solid", MapConstraint::Consistent});
    c.fields.push_back({"wall", "force", 3, "fluid", MapConstraint::Conservative});

    TransportOptions t;
    t.kind = mpi ? TransportKind::Mpi : TransportKind::Tcp;
    t.role = listen ? ConnectRole::Listen : connect ? ConnectRole::Connect : ConnectRole::Auto;
    t.bindAddress = opt["bind"];
    t.addressFile = opt["address-file"];
    if (opt.count("port")) t.connectPort = std::stoi(opt["port"]);
    t.receiveTimeout = std::stod(opt["timeout"]);
    t.connectTimeout = std::stod(opt["connect-timeout"]);

    if (mpi) {
      mpi::initialize(&argc, &argv);
      mpi::splitWorld(role, isSolid ? "fluid" : "solid");
    }
    Participant p(role, c, t, opt["token"]);
    if (isSolid)
      p.setMeshVertices("wall", ring.solidIds(), ring.solidCoordinates(), ring.solidTriangles());
    else
      p.setMeshVertices("wall", ring.fluidIds(), ring.fluidCoordinates(), ring.fluidTriangles());
    p.initialize();
    const int die = std::stoi(opt["die-at-window"]), hang = std::stoi(opt["hang-at-window"]);
    double maxErr = 0.0;
    std::vector<double> got;
    std::uint64_t passes = 0;
    while (p.isCouplingOngoing()) {
      const auto w = p.state().window;
      if (int(w) == die) {
        std::cerr << "tq-coupler-dummy (" << role << "): dying at window " << w << "\n";
        std::_Exit(9);
      }
      if (int(w) == hang) {
        std::cerr << "tq-coupler-dummy (" << role << "): hanging at window " << w << "\n";
        std::this_thread::sleep_for(std::chrono::hours(1));
      }
      const double tEnd = double(w + 1) * c.windowSize;
      // The fluid reads the solid's velocity of this pass (the first participant's data
      // are never relaxed). The solid checks the force at the start of a window: the
      // converged force of the previous window (passes in between may carry relaxed
      // values under Aitken/IQN-ILS).
      if (!isSolid || (p.state().iteration == 0 && w > 0)) {
        p.readData("wall", isSolid ? "force" : "velocity", got);
        const double tGot = isSolid ? double(w) * c.windowSize : tEnd;
        const auto want = scenario::field(ring, isSolid, !isSolid, tGot);
        for (std::size_t i = 0; i < got.size(); ++i)
          maxErr = std::max(maxErr, std::abs(got[i] - want[i]) / std::max(1.0, std::abs(want[i])));
      }
      p.writeData("wall", isSolid ? "velocity" : "force", scenario::field(ring, isSolid, isSolid, tEnd));
      p.advance(p.getMaxTimeStepSize());
      ++passes;
    }
    if (isSolid && c.maxWindows > 0) {  // the force of the last window
      p.readData("wall", "force", got);
      const auto want = scenario::field(ring, true, false, double(c.maxWindows) * c.windowSize);
      for (std::size_t i = 0; i < got.size(); ++i)
        maxErr = std::max(maxErr, std::abs(got[i] - want[i]) / std::max(1.0, std::abs(want[i])));
    }
    const auto st = p.stats();
    p.finalize();
    out["windows"] = std::to_string(p.state().window);
    out["passes"] = std::to_string(passes);
    out["max_error"] = std::to_string(maxErr);
    out["exchanges"] = std::to_string(st.exchanges);
    out["partner_nodes"] = std::to_string(p.partnerVertexCount("wall"));
    std::cout << "tq-coupler-dummy (" << role << "): " << p.state().window << " windows, " << passes
              << " passes, max relative error of received data " << maxErr << "\n";
    rc = maxErr <= 1e-12 ? 0 : 3;
  } catch (const CouplerError& e) {
    std::cerr << "tq-coupler-dummy (" << role << "): " << errorKind(e) << ": " << e.what() << "\n";
    out["error_kind"] = errorKind(e);
    rc = 2;
  } catch (const std::exception& e) {
    std::cerr << "tq-coupler-dummy (" << role << "): " << e.what() << "\n";
    out["error_kind"] = "Error";
    rc = 4;
  }
  out["exit"] = std::to_string(rc);
  writeReport();
  if (mpi) mpi::finalize();
  return rc;
}
