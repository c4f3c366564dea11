/* Table signals (gpmegen_solver.h): samples set by the runtime, linearly interpolated in t. */

#include <math.h>
#include <stddef.h>

#include "gpmegen_solver.h"

struct signal_table {
    long n;
    const double *t, *y;
};

static struct signal_table signal_tables[GPMEGEN_MAX_SIGNALS];

int gpmegen_set_signal(int k, long n, const double *t, const double *y) {
    if (k < 0 || k >= GPMEGEN_MAX_SIGNALS) return GPMEGEN_BAD_ARGUMENTS;
    if (n == 0 && t == NULL && y == NULL) {
        signal_tables[k].n = 0;
        signal_tables[k].t = signal_tables[k].y = NULL;
        return GPMEGEN_OK;
    }
    if (n < 2 || t == NULL || y == NULL) return GPMEGEN_BAD_ARGUMENTS;
    signal_tables[k].n = n;
    signal_tables[k].t = t;
    signal_tables[k].y = y;
    return GPMEGEN_OK;
}

double gpmegen_signal(int k, double x) {
    if (k < 0 || k >= GPMEGEN_MAX_SIGNALS || signal_tables[k].n < 2 || x != x) return NAN;
    const struct signal_table *table = &signal_tables[k];
    const double *t = table->t, *y = table->y;
    long n = table->n;
    if (x <= t[0]) return y[0];
    if (x >= t[n - 1]) return y[n - 1];
    long lo = 0, hi = n - 1; /* t[lo] <= x < t[hi] */
    while (hi - lo > 1) {
        long mid = lo + (hi - lo) / 2;
        if (t[mid] <= x) lo = mid;
        else hi = mid;
    }
    /* as numpy.interp: the slope times the distance from the sample below, added to its value */
    double slope = (y[hi] - y[lo]) / (t[hi] - t[lo]);
    return slope * (x - t[lo]) + y[lo];
}
