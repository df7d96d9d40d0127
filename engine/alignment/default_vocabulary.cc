// Embeds the default vocabulary with the assembler's .incbin (GNU as / LLVM integrated
// assembler): no generated source, no multi-megabyte array literal to compile. The file's path
// comes from CMake (GLAM_DEFAULT_VOCABULARY_FILE, engine/alignment/CMakeLists.txt), which also
// makes this object depend on the file so a new vocabulary is re-embedded.
#include "engine/alignment/default_vocabulary.h"

#ifndef GLAM_DEFAULT_VOCABULARY_FILE
#error "GLAM_DEFAULT_VOCABULARY_FILE must name the vocabulary file to embed"
#endif

asm(".pushsection .rodata.glam_default_vocabulary, \"a\"\n"
    ".balign 16\n"
    ".globl glam_default_vocabulary_begin\n"
    ".hidden glam_default_vocabulary_begin\n"
    "glam_default_vocabulary_begin:\n"
    ".incbin \"" GLAM_DEFAULT_VOCABULARY_FILE "\"\n"
    ".globl glam_default_vocabulary_end\n"
    ".hidden glam_default_vocabulary_end\n"
    "glam_default_vocabulary_end:\n"
    ".byte 0\n"
    ".popsection\n");

extern "C" const std::uint8_t glam_default_vocabulary_begin[];
extern "C" const std::uint8_t glam_default_vocabulary_end[];

namespace glam {

std::span<const std::uint8_t> DefaultVocabularyBytes() {
  return {glam_default_vocabulary_begin, glam_default_vocabulary_end};
}

}  // namespace glam
