// A program built against an installed shadowsense through find_package.
#include <shadowsense/shadowsense.hpp>

#include <iostream>

int main() {
  std::cout << "shadowsense " << shadowsense::version_string << '\n';
  return shadowsense::version_major == 0 ? 0 : 1;
}
