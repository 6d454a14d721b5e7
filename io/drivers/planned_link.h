// What every link that runs on a fieldbus plan shows in its generic link row
// (docs/fieldbus.md, "Running a link on a plan"): the plan in one line and,
// per traffic class, the scheduler's measured delays beside the plan's bounds.
// Shared by the kinds that can run on a plan (CAN, Modbus RTU), so `rtplc
// stats` prints them without knowing the kind.
//
// The bounds a planned link claims, per class:
//   periodic  delay <= W (the planner's worst transfer delay of a sample,
//             docs/fieldbus.md "The conditions"), packet <= L_p;
//   urgent    sent in the T_1 frame it arrived in: delay <= T_1, packet <= L_c;
//   non-RT    no delay claim (it takes what is left), fragment <= L_n max.
#pragma once

#include "fieldbus/link_plan.h"
#include "fieldbus/link_scheduler.h"
#include "io/process_image.h"

namespace rtplc::io {

// Before the threads start: the plan line and the classes' names and bounds.
void describe_planned_link(LinkStatus& ls, const fieldbus::LinkPlan& plan);
// On the link's thread (the row's one writer): the scheduler's figures.
void publish_planned_link(LinkStatus& ls, const fieldbus::LinkScheduler& s) noexcept;
// The same from figures another thread took of its scheduler (a Modbus line's).
void publish_planned_link(LinkStatus& ls, const fieldbus::LinkFigures& f) noexcept;

}  // namespace rtplc::io
