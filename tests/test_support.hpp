// Helpers shared by tacmap's tests.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>

namespace tacmap_test {

/// The message of the `Exception` that `call()` throws, or "no exception". Tests check that error
/// messages name the offending value and what was expected.
template <class Exception = std::invalid_argument, class Call>
std::string message_of(Call&& call) {
  try {
    std::forward<Call>(call)();
  } catch (const Exception& e) {
    return e.what();
  }
  return "no exception";
}

}  // namespace tacmap_test
