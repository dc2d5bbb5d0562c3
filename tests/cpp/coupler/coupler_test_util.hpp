#pragma once
// Helpers for the coupler tests: a fresh folder and token per test, the ring configuration,
// and two participants run side by side in threads over loopback TCP.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <exception>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>

#include "ring_scenario.hpp"
#include "tq/coupler/participant.hpp"

namespace tqtest {

using namespace tq::coupler;

inline std::filesystem::path freshDir() {
  static std::atomic<int> counter{0};
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  auto d = std::filesystem::temp_directory_path() / ("tq-coupler-" + std::to_string(::getpid()) + "-" +
                                                     std::to_string(counter++) + "-" + (info ? info->name() : "x"));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

inline CouplingConfig ringConfig(SchemeKind scheme, std::uint64_t windows, double dt = 1e-3) {
  CouplingConfig c;
  c.first = "solid";
  c.second = "fluid";
  c.scheme = scheme;
  c.windowSize = dt;
  c.maxWindows = windows;
  c.maxIterations = 30;
  c.tolerance = 1e-10;
  c.acceleration = AccelerationKind::Aitken;
  c.meshes.push_back({"wall", MapKind::Coincident, "solid", 1e-6});
  c.fields.push_back({"wall", "velocity", 3, "solid", MapConstraint::Consistent});
  c.fields.push_back({"wall", "force", 3, "fluid", MapConstraint::Conservative});
  return c;
}

inline TransportOptions tcp(const std::filesystem::path& dir, double timeout = 5.0) {
  TransportOptions t;
  t.addressFile = (dir / "wall.addr").string();
  t.connectTimeout = timeout;
  t.receiveTimeout = timeout;
  return t;
}

inline void setRing(Participant& p, const scenario::Ring& r, bool solid) {
  if (solid)
    p.setMeshVertices("wall", r.solidIds(), r.solidCoordinates(), r.solidTriangles());
  else
    p.setMeshVertices("wall", r.fluidIds(), r.fluidCoordinates(), r.fluidTriangles());
}

/// The ring's mesh set on `p` (solid or fluid side) and `p` initialized: connected, handshake done.
inline void startOnRing(Participant& p, const scenario::Ring& r, bool solid) {
  setRing(p, r, solid);
  p.initialize();
}

/// Couples `p` (its mesh set, initialized) to its last window: before each advance of `dt` it
/// writes the same `values` of `field` on the mesh "wall".
inline void coupleSteadily(Participant& p, const std::string& field, const std::vector<double>& values, double dt) {
  while (p.isCouplingOngoing()) {
    p.writeData("wall", field, values);
    p.advance(dt);
  }
}

/// Runs a and b concurrently; returns their exceptions (null when none).
inline std::pair<std::exception_ptr, std::exception_ptr> runPair(const std::function<void()>& a,
                                                                 const std::function<void()>& b) {
  std::exception_ptr ea, eb;
  std::thread ta([&] {
    try {
      a();
    } catch (...) {
      ea = std::current_exception();
    }
  });
  try {
    b();
  } catch (...) {
    eb = std::current_exception();
  }
  ta.join();
  return {ea, eb};
}

/// Both sides started on their rings concurrently (the solid with `cs` on `rs`, the fluid with `cf`
/// on `rf`, over loopback TCP in `dir`); returns their exceptions (null when none).
inline std::pair<std::exception_ptr, std::exception_ptr> handshakePair(
    const std::filesystem::path& dir, const CouplingConfig& cs, const scenario::Ring& rs, const CouplingConfig& cf,
    const scenario::Ring& rf, const std::string& token) {
  return runPair(
      [&] {
        Participant p("solid", cs, tcp(dir), token);
        startOnRing(p, rs, true);
      },
      [&] {
        Participant p("fluid", cf, tcp(dir), token);
        startOnRing(p, rf, false);
      });
}

/// Message of an exception of type E (fails the test for another outcome).
template <class E>
std::string messageOf(const std::exception_ptr& e) {
  if (!e) {
    ADD_FAILURE() << "expected an exception, none was thrown";
    return "";
  }
  try {
    std::rethrow_exception(e);
  } catch (const E& x) {
    return x.what();
  } catch (const std::exception& x) {
    ADD_FAILURE() << "unexpected exception type: " << x.what();
  }
  return "";
}

inline void rethrowIf(const std::exception_ptr& e) {
  if (e) std::rethrow_exception(e);
}

inline bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace tqtest
