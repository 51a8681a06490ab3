/* Instructions and estimated cycles of every ls_drive_step on the Cortex-M4F, from QEMU's execution
 * log (qemu-system-arm -singlestep -d exec,nochain: one "Trace" line per executed instruction, its
 * address the second field in brackets). Host tool of tools/bench_pil.py.
 *
 *   pil_count COSTS ENTRY RETURN LOG [HITS]
 *
 * COSTS: one line per instruction of the image, "addr size base_nom base_up taken_nom taken_up"
 * (hex address and size, then the cycle model's costs of tools/bench_pil.py: the instruction's
 * cycles, and the extra cycles when it branches, i.e. when the next executed address is not the
 * following instruction). ENTRY: the address of ls_drive_step; RETURN: the address after the replay's
 * one call of it. A step runs from ENTRY up to RETURN (the call's return). Prints one line per step:
 * "instructions cycles_nominal cycles_upper", then "unknown N" (executed addresses not in COSTS). LOG
 * is read as it is written (a named pipe: the log of a replay is gigabytes). HITS: written at the end,
 * "addr executions taken" of every instruction of COSTS executed inside the steps. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    unsigned addr, size, base_nom, base_up, taken_nom, taken_up;
    unsigned long long hits, taken;
} cost;

static cost *costs;
static size_t n_costs;

static cost *find(unsigned a)
{
    size_t lo = 0, hi = n_costs;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (costs[mid].addr < a) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    return lo < n_costs && costs[lo].addr == a ? &costs[lo] : NULL;
}

static int by_addr(const void *x, const void *y)
{
    const cost *a = x, *b = y;
    return a->addr < b->addr ? -1 : a->addr > b->addr;
}

int main(int argc, char **argv)
{
    FILE *f, *log;
    char line[512];
    size_t cap = 1024;
    unsigned entry, ret, prev = 0;
    int in_step = 0, have_prev = 0;
    unsigned long long n = 0, nom = 0, up = 0, unknown = 0;
    if ((argc != 5 && argc != 6) || (f = fopen(argv[1], "r")) == NULL) {
        fprintf(stderr, "usage: pil_count COSTS ENTRY RETURN LOG [HITS]\n");
        return 2;
    }
    entry = (unsigned)strtoul(argv[2], NULL, 16);
    ret = (unsigned)strtoul(argv[3], NULL, 16);
    costs = malloc(cap * sizeof *costs);
    while (costs != NULL && fgets(line, sizeof line, f) != NULL) {
        cost c;
        c.hits = c.taken = 0;
        if (sscanf(line, "%x %x %u %u %u %u", &c.addr, &c.size, &c.base_nom, &c.base_up, &c.taken_nom, &c.taken_up) !=
            6) {
            continue;
        }
        if (n_costs == cap) {
            cap *= 2;
            costs = realloc(costs, cap * sizeof *costs);
            if (costs == NULL) {
                break;
            }
        }
        costs[n_costs++] = c;
    }
    fclose(f);
    if (costs == NULL) {
        return 2;
    }
    qsort(costs, n_costs, sizeof *costs, by_addr);
    if ((log = fopen(argv[4], "r")) == NULL) {
        return 2;
    }
    while (fgets(line, sizeof line, log) != NULL) {
        const char *b;
        unsigned pc;
        if (strncmp(line, "Trace ", 6) != 0 || (b = strchr(line, '[')) == NULL || (b = strchr(b, '/')) == NULL) {
            continue;
        }
        pc = (unsigned)strtoul(b + 1, NULL, 16);
        if (in_step && have_prev) { /* the previous instruction's cost, now that its successor is known */
            cost *c = find(prev);
            if (c == NULL) {
                unknown++;
                nom++;
                up++;
            } else {
                const int taken = pc != prev + c->size;
                c->hits++;
                c->taken += taken ? 1u : 0u;
                nom += c->base_nom + (taken ? c->taken_nom : 0u);
                up += c->base_up + (taken ? c->taken_up : 0u);
            }
        }
        if (!in_step && pc == entry) {
            in_step = 1;
            n = nom = up = 0;
        }
        if (in_step && pc == ret) {
            printf("%llu %llu %llu\n", n, nom, up);
            in_step = 0;
        }
        if (in_step) {
            n++;
        }
        prev = pc;
        have_prev = 1;
    }
    fclose(log);
    printf("unknown %llu\n", unknown);
    if (argc == 6 && (f = fopen(argv[5], "w")) != NULL) {
        size_t i;
        for (i = 0; i < n_costs; i++) {
            if (costs[i].hits != 0u) {
                fprintf(f, "%x %llu %llu\n", costs[i].addr, costs[i].hits, costs[i].taken);
            }
        }
        fclose(f);
    }
    return 0;
}
