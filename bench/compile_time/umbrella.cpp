// Compile-time measurement (README, "Compile time"): the umbrella header and dense SIFT alone.
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/tacmap.hpp"

int main() { return 0; }
