// The output of the `evaluate` subcommands: one JSON document, on stdout or in a file.
#pragma once
#include "common.h"
#include <iostream>
#include <string>

namespace shapemap::cli {

// out empty: j on stdout (indented); else written to out (atomically, write_json).
inline void emit_evaluation(const std::string& out, const nlohmann::json& j) {
  if (out.empty())
    std::cout << j.dump(2) << "\n";
  else
    write_json(out, j);
}

}  // namespace shapemap::cli
