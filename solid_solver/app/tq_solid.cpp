// tq-solid command line entry (the driver lives in the library: src/app/app.cpp).
#include <iostream>

#include "tq/app/app.hpp"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return tq::runSolid(args, std::cout, std::cerr);
}
