// The command line frame_time and roofline share, on the programs' parser
// (examples/common/cli.hpp: --help on stdout exit 0, --version, errors on stderr exit 2).
//
// declare_frame_options(parser, usage, options)
//   ensures: parser's --help prints `usage` as given; --model PATH, --frames N, --rounds R
//     (N, R in 1..100000) and --json are declared into `options`, whose values are the defaults.
//   requires: options outlives parser.parse().
//
// Threading: no shared state; one parser per thread, as cli::Parser.
#pragma once

#include "examples/common/cli.hpp"

#include <string>
#include <string_view>

namespace bench {

struct FrameOptions {
  std::string model_path = "models/default.ssm";
  int frames = 20;
  int rounds = 7;
  bool json = false;
};

inline void declare_frame_options(cli::Parser& p, std::string_view usage, FrameOptions& o) {
  p.help_text(std::string(usage));
  p.option("--model", "PATH", "the model file", o.model_path);
  p.option("--frames", "N", "generator frames per round", o.frames).range(1, 100000);
  p.option("--rounds", "R", "rounds", o.rounds).range(1, 100000);
  p.flag("--json", "the figures as JSON on stdout", o.json);
}

} // namespace bench
