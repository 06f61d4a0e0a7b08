// tacmap: the readable name of a type, for error messages that name a user's own type
// (a custom descriptor that returned NaN, a policy that lacks a hook).
#pragma once

#include <cstdlib>
#include <memory>
#include <string>
#include <typeinfo>

#if defined(__GNUG__) || defined(__clang__)
#include <cxxabi.h>
#endif

namespace tacmap::detail {

/// `T`'s name as the source spells it where the compiler's ABI can demangle it (GCC, Clang:
/// "(anonymous namespace)::my_descriptor"), else the implementation's `typeid(T).name()`.
template <class T>
[[nodiscard]] std::string type_name() {
  const char* raw = typeid(T).name();
#if defined(__GNUG__) || defined(__clang__)
  int status = 0;
  const std::unique_ptr<char, void (*)(void*)> readable(
      abi::__cxa_demangle(raw, nullptr, nullptr, &status), std::free);
  if (status == 0 && readable) return readable.get();
#endif
  return raw;
}

}  // namespace tacmap::detail
