// Output umbrella: event sinks (the EventSink concept, OutputFrame, CSV, JSON lines, TUIO 1.1
// over UDP) and the OSC encoder/decoder they use. Part of the runtime: needs OpenCV core and
// POSIX sockets only.
#pragma once

#include <shadowsense/output/csv_sink.hpp>
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/output/json_lines_sink.hpp>
#include <shadowsense/output/osc.hpp>
#include <shadowsense/output/text_format.hpp>
#include <shadowsense/output/tuio_sink.hpp>
#include <shadowsense/output/udp_sender.hpp>
