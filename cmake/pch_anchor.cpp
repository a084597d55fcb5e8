// The owner of a shared precompiled header (cmake/precompiled_headers.cmake): an empty
// translation unit, so the header is compiled once and the tests or programs reuse it.
