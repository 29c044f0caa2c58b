// The C library's heap tuned for clients that receive frames of megabytes many times a second
// (docs/performance.md, "The light change"). Freed frame buffers stay in the heap for the next
// frame instead of going back to the operating system, so a frame does not fault its buffers'
// pages in afresh. Not for the server, whose resident memory must follow its load down: it reuses
// its frame buffers without it, and gives idle free memory back itself (server/heap.h).
#pragma once

namespace caustica::wire {

// Call once at the start of main, before any thread starts. Without glibc it does nothing.
void keep_frame_buffers();

}  // namespace caustica::wire
