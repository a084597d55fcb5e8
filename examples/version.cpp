// Prints the library version (placeholder until the demo lands).
#include <shadowsense/shadowsense.hpp>
#include <iostream>
int main() { std::cout << "shadowsense " << shadowsense::version_string << '\n'; }
