// The C library's heap tuned for processes that send or receive frames of megabytes many times a
// second (docs/performance.md, "The light change"). Freed frame buffers stay in the heap for the
// next frame instead of going back to the operating system, so a frame does not fault its
// buffers' pages in afresh.
#pragma once

namespace caustica::wire {

// Call once at the start of main, before any thread starts. Without glibc it does nothing.
void keep_frame_buffers();

}  // namespace caustica::wire
