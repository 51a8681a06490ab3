/* linsense simulator as one translation unit: what the extension (linsense._ctrl) compiles instead of
 * the parts, so that the time loop inlines their helpers as when they were one file (same speed, same
 * arithmetic; see ls_sim_internal.h). Not compiled together with the parts' own objects. */
#define LS_SIM_UNITY 1

#include "ls_sim_plant.c"
#include "ls_sim_sat.c"
#include "ls_sim_inverter.c"
#include "ls_sim_sensors.c"
#include "ls_sim_mech.c"
#include "ls_sim_record.c"
#include "ls_sim.c"
