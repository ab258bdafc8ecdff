#pragma once
// A 5 x 7 pixel bitmap font for the renderer's overlay (time, counters, legend labels, messages): every
// printable ASCII character, lower case with its x-height of 5 pixels (g, j, p, q and y end on the last row).
#include <cstdint>
#include <string_view>

namespace mca::render {

constexpr int kGlyphWidth = 5, kGlyphHeight = 7;
// Horizontal advance of one character in font pixels (the glyph and one pixel of space).
constexpr int kGlyphAdvance = kGlyphWidth + 1;

// The glyph of c: row r (0 = top) has bit (4 - x) set where pixel x is lit. Any other byte (a control
// character, each byte of a UTF-8 character) is drawn as '?', so it shows instead of vanishing.
const std::uint8_t* glyph(char c);

// Width of a line of text in font pixels.
int text_width(std::string_view text);

}  // namespace mca::render
