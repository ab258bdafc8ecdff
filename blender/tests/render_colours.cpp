// Prints the colours of mca's renderer (render::fragment_colours) for the automata of a frame, so that the
// add-on's copy of the rule (blender/io_import_mca/reader.py) is checked against the renderer itself.
// stdin: the object count, the automata count, then per automaton its object and fragment.
// stdout: per automaton "r g b".
#include <cstdio>
#include <algorithm>
#include <iostream>

#include "analysis/fragments.hpp"
#include "core/model.hpp"
#include "render/snapshot.hpp"

int main() {
  std::size_t objects = 0, n = 0;
  if (!(std::cin >> objects >> n)) return 2;
  mca::Model model;
  model.object_names.resize(objects);
  model.mass.assign(n, 1.0f);
  model.object.resize(n);
  mca::analysis::Fragments fragments;
  fragments.id.resize(n);
  for (std::size_t a = 0; a < n; ++a) {
    if (!(std::cin >> model.object[a] >> fragments.id[a])) return 2;
    fragments.count = std::max(fragments.count, fragments.id[a] + 1);
  }
  for (const auto& c : mca::render::fragment_colours(model, fragments)) std::printf("%d %d %d\n", c[0], c[1], c[2]);
  return 0;
}
