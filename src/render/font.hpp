#pragma once
// A 5 x 7 pixel bitmap font for the renderer's overlay (time, counters, legend labels, messages): every
// printable ASCII character, lower case with an x-height of 5 pixels and descenders of 2.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace mca::render {

// A glyph's width and height in font pixels, and its rows with the descenders below the line (g, j, p, q, y:
// drawn in the space between lines, which is 4 font pixels).
constexpr int kGlyphWidth = 5, kGlyphHeight = 7, kGlyphRows = 9;
// Horizontal advance of one character in font pixels (the glyph and one pixel of space).
constexpr int kGlyphAdvance = kGlyphWidth + 1;

// The glyph of c, kGlyphRows rows: row r (0 = top) has bit (4 - x) set where pixel x is lit. Any other byte
// (a control character, each byte of a UTF-8 character) is drawn as '?', so it shows instead of vanishing.
const std::uint8_t* glyph(char c);

// Width of a line of text in font pixels.
int text_width(std::string_view text);

// `text` with each UTF-8 character (of 2 to 4 bytes) as one '?' (each of its bytes was a '?': "Äñ" read
// "????"), so that a byte is a glyph; other bytes as they are (glyph() draws control characters as '?').
std::string one_glyph_per_character(std::string_view text);

// `text` in lines of at most `width` characters (at least 1), broken at spaces where there are (a word longer
// than a line at the width), each line without the spaces it was broken at; none for an empty text.
std::vector<std::string_view> wrap_text(std::string_view text, std::size_t width);

}  // namespace mca::render
