// A Modbus line's I/O thread (see line.h).
#include "io/drivers/modbus/line.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <utility>

#include "io/link/backoff.h"
#include "kernel_rt/clock.h"

namespace rtplc::modbus {

Line::Line(const ModbusSettings& s, std::vector<uint32_t> slaves, Exchange& x, LineOptions opt)
    : s_(s), x_(x), opt_(std::move(opt)), book_(s, slaves, x, opt_), queue_(256) {
  if (book_.first().plan) plan_line(*book_.first().plan);
}

// ---- on a plan ----------------------------------------------------------------

namespace {

int data_bytes(const Block& b) {
  const bool bits = b.table == Table::kCoil || b.table == Table::kDiscreteInput;
  return bits ? (b.count + 7) / 8 : 2 * b.count;
}

}  // namespace

void Line::plan_line(const fieldbus::LinkPlan& lp) {
  timing_ = &*lp.design.timing;
  fieldbus::SchedulerSetup ss;
  ss.t1 = lp.plan.t1;
  ss.ln = lp.plan.ln_max;
  for (uint32_t ui = 0; ui < units_.size(); ++ui) {
    Unit& u = units_[ui];
    for (uint32_t bi = 0; bi < u.blocks.size(); ++bi) {
      const UnitBlock& ub = u.blocks[bi];
      if (ub.traffic == ChannelMap::Traffic::kNonRt) {
        nonrt_.push_back({ui, bi});
        continue;
      }
      const ChannelMap& m = s_.reads[u.reads[ub.block.items.front()].map];
      const fieldbus::LoopPlan* loop = lp.loop(m.loop);
      if (!loop) continue;  // the config refused it
      const int64_t frames = int64_t{1} << loop->shift;
      periodic_.push_back({ui, bi});
      ss.periodic.push_back({frames, std::max<int64_t>(loop->offset, 0) % frames, timing_->packet(data_bytes(ub.block))});
    }
  }
  write_slot_.assign(s_.writes.size(), -1);
  for (uint32_t j = 0; j < s_.writes.size(); ++j) {
    const ChannelMap& m = s_.writes[j];
    for (const Unit& u : units_) {
      if (u.cfg->name != m.slave) continue;
      write_slot_[j] = static_cast<int32_t>(ss.urgent.size());
      ss.urgent.push_back(timing_->packet(m.item.type == ItemType::kBit ? 1 : 2 * width(m.item)));
    }
  }
  pending_.assign(ss.urgent.size(), WriteJob{});
  pending_set_.assign(ss.urgent.size(), 0);
  sched_ = std::make_unique<fieldbus::LinkScheduler>(std::move(ss), &kernel_rt::monotonic_now_ns);
}

void Line::run_planned() noexcept {
  const int64_t t1 = sched_->t1();
  epoch_ = (kernel_rt::monotonic_now_ns() / t1 + 1) * t1;  // T_1 frames on the clock's multiples of T_1
  sched_->start(epoch_);
  while (!stop_.load(std::memory_order_relaxed)) {
    const int64_t now = kernel_rt::monotonic_now_ns();
    int64_t wake = now + opt_.wake_ns;
    if (ensure_connected(now)) {
      WriteJob job;
      while (queue_.pop(job)) {
        const int32_t slot = write_slot_[job.write];
        if (slot < 0) continue;
        pending_[static_cast<size_t>(slot)] = job;  // the bridge keeps one write per item in flight
        pending_set_[static_cast<size_t>(slot)] = 1;
        sched_->urgent_ready(static_cast<uint32_t>(slot), now);
      }
      if (nonrt_active_ == SIZE_MAX) {
        for (size_t k = 0; k < nonrt_.size(); ++k) {
          UnitBlock& b = units_[nonrt_[k].unit].blocks[nonrt_[k].block];
          if (now < b.next_due) continue;
          const int64_t period = b.block.period_ns;
          b.next_due = (now / period + 1) * period;
          b.cursor = 0;
          nonrt_active_ = k;
          sched_->nonrt_ready(now);
          break;
        }
      }
      sched_->tick(now, *this);
    } else {
      wake = std::min(wake, std::max(book_.next_connect(), now));
    }
    book_.publish_all(kernel_rt::monotonic_now_ns());
    x_.planned[units_.front().slave].store(sched_->figures());
    const int64_t t = kernel_rt::monotonic_now_ns();
    if (t >= epoch_) wake = std::min(wake, epoch_ + ((t - epoch_) / t1 + 1) * t1);
    kernel_rt::sleep_until_ns(wake);
  }
  // Stopping: what the bridge queued last (the tasks' safe values) still goes out.
  if (client_.connected()) {
    WriteJob job;
    while (queue_.pop(job)) write_one(job);
    for (size_t i = 0; i < pending_.size(); ++i) {
      if (pending_set_[i]) write_one(pending_[i]);
    }
  }
  x_.planned[units_.front().slave].store(sched_->figures());
  client_.close();
}

fieldbus::SendOutcome Line::send_periodic(uint32_t slot) noexcept {
  if (!client_.connected()) return fieldbus::SendOutcome::kFailed;
  Unit& u = units_[periodic_[slot].unit];
  UnitBlock& b = u.blocks[periodic_[slot].block];
  const int64_t now = kernel_rt::monotonic_now_ns();
  if (now < u.quiet_until) {
    ++u.st.polls_offline;  // a quiet RTU unit: not asked (counted offline, not a missed window)
    return fieldbus::SendOutcome::kNothing;
  }
  poll_block(u, b, now);
  return fieldbus::SendOutcome::kSent;
}

fieldbus::SendOutcome Line::send_urgent(uint32_t slot) noexcept {
  if (!pending_set_[slot]) return fieldbus::SendOutcome::kNothing;
  if (!client_.connected()) return fieldbus::SendOutcome::kFailed;
  write_one(pending_[slot]);
  pending_set_[slot] = 0;
  return fieldbus::SendOutcome::kSent;
}

fieldbus::Nanos Line::send_nonrt(fieldbus::Nanos budget, bool& more) noexcept {
  more = false;
  if (nonrt_active_ == SIZE_MAX || !client_.connected()) return 0;
  Unit& u = units_[nonrt_[nonrt_active_].unit];
  UnitBlock& b = u.blocks[nonrt_[nonrt_active_].block];
  const std::vector<uint32_t>& items = b.block.items;
  const bool bits = b.block.table == Table::kCoil || b.block.table == Table::kDiscreteInput;
  // As many whole items from the cursor as fit the budget (never one cut in two).
  const uint16_t start = s_.reads[u.reads[items[b.cursor]].map].item.address;
  size_t end = b.cursor;
  uint32_t count = 0;
  while (end < items.size()) {
    const Address& a = s_.reads[u.reads[items[end]].map].item;
    const uint32_t need = std::max<uint32_t>(count, uint32_t{a.address} + (bits ? 1u : width(a)) - start);
    const int bytes = bits ? static_cast<int>((need + 7) / 8) : static_cast<int>(2 * need);
    if (timing_->packet(bytes) > budget || need > (bits ? u.cfg->max_bits : u.cfg->max_registers)) break;
    count = need;
    ++end;
  }
  more = true;
  if (end == b.cursor) return 0;  // not even one item fits what is left of this frame
  const int bytes = bits ? static_cast<int>((count + 7) / 8) : static_cast<int>(2 * count);
  client_.set_unit(u.cfg->unit);
  client_.set_timeout_ns(u.timeout_ns);
  uint16_t words[2000];  // MODBUS_MAX_READ_BITS
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  const Outcome o = client_.read(b.block.table, start, static_cast<uint16_t>(count), words);
  const int64_t answered = kernel_rt::monotonic_now_ns();
  book_.record(u, o, t0, answered);
  if (o.ok()) {
    book_.store_items(u, b, b.cursor, end, start, words, answered);
    ++u.st.polls_completed;
  } else {
    for (size_t i = b.cursor; i < end; ++i) {
      Read& r = u.reads[items[i]];
      x_.samples[r.map].store(ItemSample{r.last, answered, 0, static_cast<uint8_t>(o.kind == Outcome::Kind::kException ? o.code : 0)});
    }
  }
  b.cursor = end;
  more = b.cursor < items.size();
  if (!more) nonrt_active_ = SIZE_MAX;
  return timing_->packet(bytes);
}

Line::~Line() { join(); }

Result<void> Line::start() {
  const SlaveConfig& first = book_.first();
  auto c = Client::rtu({first.device, first.baud, first.parity, first.data_bits, first.stop_bits});
  if (!c) return make_error(c.error());
  client_ = std::move(*c);
  book_.publish_all(kernel_rt::monotonic_now_ns());
  const std::string& name = book_.name();
  kernel_rt::ThreadSpec spec;
  spec.name = "mb-" + name.substr(name.rfind('/') + 1);
  spec.fifo_priority = opt_.priority;
  if (opt_.cpu >= 0) spec.cpu = static_cast<unsigned>(opt_.cpu);
  auto t = kernel_rt::start_thread(spec, [this] { run(); });
  if (!t) return make_error(fmt::format("modbus line {}: {}", name, t.error()));
  thread_ = std::move(*t);
  started_ = true;
  return {};
}

void Line::join() {
  if (!started_) return;
  request_stop();
  thread_.join();
  started_ = false;
}

void Line::run() noexcept {
  if (sched_) {
    run_planned();
    return;
  }
  while (!stop_.load(std::memory_order_relaxed)) {
    int64_t now = kernel_rt::monotonic_now_ns();
    int64_t wake = now + opt_.wake_ns;
    if (ensure_connected(now)) {
      serve_writes();
      for (Unit& u : units_) {
        for (UnitBlock& b : u.blocks) {
          if (!client_.connected()) break;
          now = kernel_rt::monotonic_now_ns();
          if (now < b.next_due) continue;
          if (now < u.quiet_until) {
            UnitBook::skip_slot(u, b, now);  // a quiet unit: this poll is not made
            continue;
          }
          poll_block(u, b, now);
        }
      }
    } else {
      for (Unit& u : units_) {
        for (UnitBlock& b : u.blocks) {
          if (now >= b.next_due) UnitBook::skip_slot(u, b, now);
        }
      }
      wake = std::min(wake, std::max(book_.next_connect(), now));
    }
    book_.publish_all(kernel_rt::monotonic_now_ns());
    for (const Unit& u : units_) wake = std::min(wake, UnitBook::next_due(u));
    kernel_rt::sleep_until_ns(wake);
  }
  // Stopping: what the bridge queued last (the tasks' safe values) still goes out.
  if (client_.connected()) serve_writes();
  client_.close();
}

bool Line::ensure_connected(int64_t now) noexcept {
  if (client_.connected()) return true;
  if (!book_.connect_due(now)) return false;
  book_.connecting();
  client_.set_timeout_ns(units_.front().timeout_ns);
  const Outcome o = client_.connect();
  if (o.ok()) {
    book_.connected();
    return true;
  }
  book_.connect_failed(o, now);
  return false;
}

void Line::drop_connection(int64_t now, const char* why) noexcept {
  client_.close();
  book_.dropped(now, why);
}

void Line::serve_writes() noexcept {
  WriteJob job;
  while (queue_.pop(job)) write_one(job);
}

void Line::write_one(const WriteJob& job) noexcept {
  Unit* u = book_.unit_of_write(job.write);
  if (!u || !client_.connected()) {
    book_.write_done(job, nullptr);
    return;
  }
  client_.set_unit(u->cfg->unit);
  client_.set_timeout_ns(u->timeout_ns);
  Outcome o;
  for (uint32_t attempt = 0; attempt <= u->cfg->retries; ++attempt) {
    const int64_t t0 = kernel_rt::monotonic_now_ns();
    o = client_.write(s_.writes[job.write].item, job.words);
    book_.record(*u, o, t0, kernel_rt::monotonic_now_ns());
    if (o.kind != Outcome::Kind::kTimeout) break;
    client_.flush();
  }
  book_.write_done(job, &o);
  if (o.kind == Outcome::Kind::kLink) drop_connection(kernel_rt::monotonic_now_ns(), "connection lost on a write");
}

void Line::poll_block(Unit& u, UnitBlock& b, int64_t now) noexcept {
  const int64_t due = UnitBook::take_slot(u, b, now);
  client_.set_unit(u.cfg->unit);
  client_.set_timeout_ns(u.timeout_ns);
  uint16_t words[2000];  // MODBUS_MAX_READ_BITS
  Outcome o;
  for (uint32_t attempt = 0; attempt <= u.cfg->retries; ++attempt) {
    const int64_t t0 = kernel_rt::monotonic_now_ns();
    o = client_.read(b.block.table, b.block.start, b.block.count, words);
    book_.record(u, o, t0, kernel_rt::monotonic_now_ns());
    if (o.kind != Outcome::Kind::kTimeout && o.kind != Outcome::Kind::kProtocol && o.kind != Outcome::Kind::kBadCrc) break;
    client_.flush();
  }
  const int64_t answered = kernel_rt::monotonic_now_ns();
  if (const char* why = book_.poll_done(u, b, o, words, due, answered)) drop_connection(answered, why);
}

}  // namespace rtplc::modbus
