// tq-solid command line entry (the driver lives in the library: src/app/app.cpp).
#include <iostream>

#include "tq/app/app.hpp"
#include "tq/io/input.hpp"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  // tq-solid --print-input solid_input.h5: what the reader made of the file, as JSON (exit 2 on bad input)
  if (args.size() == 2 && args[0] == "--print-input") {
    try {
      std::cout << tq::inputJson(tq::readSolidInput(args[1])) << "\n";
      return 0;
    } catch (const std::exception& e) {
      std::cerr << "tq-solid: " << e.what() << "\n";
      return 2;
    }
  }
  return tq::runSolid(args, std::cout, std::cerr);
}
