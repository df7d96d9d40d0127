// The bytes of the vocabulary shipped with GLAM (data/vocabulary/glam_default.vocab), embedded
// into the library at build time so that `glam map` finds it without flags, from any working
// directory and after `install` (no data-file lookup that could fail at run time). Parsed by
// VocabularyTree::Default(); see data/vocabulary/README.md for how the file was made.
#pragma once

#include <cstdint>
#include <span>

namespace glam {

std::span<const std::uint8_t> DefaultVocabularyBytes();

}  // namespace glam
