// tq-coupler-bench: round-trip exchange time over loopback TCP.
//
// Two participants (solid and fluid, explicit scheme, one DATA message each way per window)
// run in two threads of this process and do nothing but exchange: the solid's advance() is one
// round trip (send velocity, receive force). Prints the median, 10th and 90th percentiles
// of many round trips, and the share spent mapping.
//
//   tq-coupler-bench [--nodes 2000] [--exchanges 2000] [--map coincident|projection]
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <thread>

#include "ring_scenario.hpp"
#include "tq/coupler/participant.hpp"
#include "tq/coupler/wire.hpp"

using namespace tq::coupler;

int main(int argc, char** argv) {
  int nodes = 2000, exchanges = 2000;
  std::string map = "coincident";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--nodes")
      nodes = std::stoi(argv[i + 1]);
    else if (a == "--exchanges")
      exchanges = std::stoi(argv[i + 1]);
    else if (a == "--map")
      map = argv[i + 1];
    else {
      std::cerr << "usage: tq-coupler-bench [--nodes N] [--exchanges N] [--map KIND]\n";
      return 4;
    }
  }
  scenario::Ring ring;
  ring.nLayers = 2;
  ring.nTheta = std::max(3, nodes / ring.nLayers);
  const int n = ring.nodes();

  CouplingConfig c;
  c.first = "solid";
  c.second = "fluid";
  c.scheme = SchemeKind::Explicit;
  c.windowSize = 1e-4;
  c.maxWindows = std::uint64_t(exchanges) + 1;
  c.meshes.push_back({"wall", parseMapKind(map), "solid", 1e-6});
  c.fields.push_back({"wall", "velocity", 3, "solid", MapConstraint::Consistent});
  c.fields.push_back({"wall", "force", 3, "fluid", MapConstraint::Conservative});
  TransportOptions t;
  const auto dir = std::filesystem::temp_directory_path() / ("tq-bench-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  t.addressFile = (dir / "wall.addr").string();
  t.connectTimeout = t.receiveTimeout = 30;

  std::thread fluid([&] {
    Participant p("fluid", c, t, "bench");
    p.setMeshVertices("wall", ring.fluidIds(), ring.fluidCoordinates());
    p.initialize();
    const auto f = scenario::field(ring, false, false, 0.0);
    while (p.isCouplingOngoing()) {
      p.writeData("wall", "force", f);
      p.advance(c.windowSize);
    }
    p.finalize();
  });
  Participant p("solid", c, t, "bench");
  p.setMeshVertices("wall", ring.solidIds(), ring.solidCoordinates(), ring.solidTriangles());
  p.initialize();
  const auto v = scenario::field(ring, true, true, 0.0);
  std::vector<double> us;
  us.reserve(std::size_t(exchanges));
  // Window 0 warms up (first allocation of the buffers); then time each round trip.
  bool first = true;
  while (p.isCouplingOngoing()) {
    p.writeData("wall", "velocity", v);
    const auto t0 = std::chrono::steady_clock::now();
    p.advance(c.windowSize);
    const double dt = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    if (!first) us.push_back(dt);
    first = false;
  }
  const auto st = p.stats();
  p.finalize();
  fluid.join();
  std::filesystem::remove_all(dir);

  std::sort(us.begin(), us.end());
  auto pct = [&](double q) { return us[std::size_t(q * double(us.size() - 1))]; };
  // CRC cost of one message of this size, for the record.
  std::vector<std::uint8_t> buf(std::size_t(24 * n + 64), 1);
  const auto c0 = std::chrono::steady_clock::now();
  std::uint32_t crc = 0;
  for (int i = 0; i < 200; ++i) crc ^= wire::crc32(buf.data(), buf.size());
  const double crcUs = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - c0).count() / 200.0;
  std::printf(
      "tq-coupler-bench: %d nodes x 3 components, %zu round trips over loopback TCP "
      "(map %s)\n",
      n, us.size(), map.c_str());
  std::printf(
      "round trip (send %d doubles, receive %d doubles): median %.1f us, p10 %.1f us, "
      "p90 %.1f us\n",
      3 * n, 3 * n, pct(0.5), pct(0.1), pct(0.9));
  std::printf("message size %llu bytes each way; CRC-32 of one message %.1f us (%x)\n",
              (unsigned long long)(st.bytesSent / std::max<std::uint64_t>(1, st.exchanges)), crcUs, crc & 0xF);
  std::printf("mapping: %.2f us per exchange\n",
              1e6 * st.secondsMapping / double(std::max<std::uint64_t>(1, st.exchanges)));
  return 0;
}
