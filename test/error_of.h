// The message of the exception of type E that f throws ("" when it throws none): for tests that
// check what an error says.
#pragma once

#include <functional>
#include <string>

namespace se3_test {

template <class E>
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  return "";
}

}  // namespace se3_test
