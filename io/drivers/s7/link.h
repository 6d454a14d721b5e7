// The shared link machinery (io/link/: sockets, timers, round-trip histogram,
// lock-free handoff, reconnect backoff) under the names the S7 code uses.
#pragma once

#include "io/link/backoff.h"
#include "io/link/handoff.h"
#include "io/link/rtt_histogram.h"
#include "io/link/socket_util.h"
#include "io/link/timer_heap.h"

namespace rtplc::s7 {

using link::BoundedQueue;
using link::connect_error;
using link::Endpoint;
using link::errno_text;
using link::listen_on;
using link::local_port;
using link::parse_endpoint;
using link::raise_fd_limit;
using link::resolve_endpoint;
using link::RttHistogram;
using link::SnapshotSlot;
using link::start_connect;
using link::TimerHeap;
using link::UniqueFd;

}  // namespace rtplc::s7
