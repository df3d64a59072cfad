/*
 * A day of the lettuce season under a controller compiled by `ghm compile`, the plant
 * played by the controller's own model (ghm_controller_plant_step).
 *
 *   cargo build --release
 *   target/release/ghm compile models/lettuce.ghm --controller mpc --horizon 1h --out ctl
 *   cc -I ctl/include examples/c/lettuce_day.c -L ctl/lib -lghm_controller -lghm \
 *      -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc -o lettuce_day
 *   ./lettuce_day WEATHER.csv [STEPS [START_ROW]]
 *
 * WEATHER.csv has a header row naming its columns and one row per control period; the
 * controller names the columns it reads (for the lettuce model: rad_Wm2, co2_out_kgm3,
 * temp_out_C, vapdens_out_kgm3, as in ghm's Venlo file, whose season starts at row 1394).
 * STEPS defaults to one day of control periods. Prints one CSV row per step: the state, the
 * input decided (both to the last bit, %.17g), the solver's iterations and solve time.
 */
#include "ghm_controller.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_LINE 65536
#define MAX_COLUMNS 256

/* The weather columns the controller reads, row by row from START_ROW. */
typedef struct {
    double *values; /* rows x width, row-major */
    size_t rows;
    size_t width;
} Weather;

static int fail(const char *what) {
    fprintf(stderr, "lettuce_day: %s: %s\n", what, ghm_last_error());
    return 1;
}

/* Splits `line` at commas in place; returns the number of fields. */
static size_t split(char *line, char **fields, size_t max) {
    size_t n = 0;
    char *p = line;
    while (n < max) {
        fields[n++] = p;
        char *comma = strchr(p, ',');
        if (!comma)
            break;
        *comma = '\0';
        p = comma + 1;
    }
    char *end = fields[n - 1] + strcspn(fields[n - 1], "\r\n");
    *end = '\0';
    return n;
}

static int read_weather(const char *path, GhmController *c, size_t width, size_t start_row,
                        Weather *w) {
    FILE *f = fopen(path, "r");
    if (!f) {
        perror(path);
        return 1;
    }
    static char line[MAX_LINE];
    char *fields[MAX_COLUMNS];
    size_t column[MAX_COLUMNS];
    if (!fgets(line, sizeof line, f)) {
        fprintf(stderr, "lettuce_day: %s is empty\n", path);
        fclose(f);
        return 1;
    }
    size_t n = split(line, fields, MAX_COLUMNS);
    for (size_t j = 0; j < width; j++) {
        const char *name = ghm_controller_name(c, GHM_QUANTITY_DISTURBANCE, j);
        size_t k = 0;
        while (k < n && strcmp(fields[k], name) != 0)
            k++;
        if (k == n) {
            fprintf(stderr, "lettuce_day: %s has no column %s\n", path, name);
            fclose(f);
            return 1;
        }
        column[j] = k;
    }
    size_t capacity = 1024, row = 0;
    w->values = malloc(capacity * width * sizeof(double));
    w->rows = 0;
    w->width = width;
    while (fgets(line, sizeof line, f)) {
        if (row++ < start_row)
            continue;
        size_t got = split(line, fields, MAX_COLUMNS);
        if (w->rows == capacity) {
            capacity *= 2;
            w->values = realloc(w->values, capacity * width * sizeof(double));
        }
        for (size_t j = 0; j < width; j++) {
            char *end = NULL;
            double v = column[j] < got ? strtod(fields[column[j]], &end) : 0.0;
            if (column[j] >= got || end == fields[column[j]]) {
                fprintf(stderr, "lettuce_day: %s row %zu: no number in column %zu\n", path,
                        row, column[j] + 1);
                fclose(f);
                return 1;
            }
            w->values[w->rows * width + j] = v;
        }
        w->rows++;
    }
    fclose(f);
    return 0;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s WEATHER.csv [STEPS [START_ROW]]\n", argv[0]);
        return 2;
    }
    GhmController *c = NULL;
    if (ghm_controller_new(&c) != GHM_STATUS_OK)
        return fail("cannot build the controller");
    GhmSizes s;
    if (ghm_controller_sizes(c, &s) != GHM_STATUS_OK)
        return fail("sizes");
    size_t steps = argc > 2 ? strtoul(argv[2], NULL, 10) : (size_t)(86400.0 / s.sample_period_s);
    size_t start_row = argc > 3 ? strtoul(argv[3], NULL, 10) : 0;

    Weather w;
    if (read_weather(argv[1], c, s.disturbances, start_row, &w) != 0)
        return 1;
    if (w.rows < steps + s.forecast_rows - 1) {
        fprintf(stderr, "lettuce_day: %zu weather rows; %zu steps with a forecast of %zu rows need %zu\n",
                w.rows, steps, s.forecast_rows, steps + s.forecast_rows - 1);
        return 1;
    }

    double *x = malloc(s.states * sizeof(double));
    double *next = malloc(s.states * sizeof(double));
    double *u = malloc(s.inputs * sizeof(double));
    double *u_prev = malloc(s.inputs * sizeof(double));
    if (ghm_controller_start(c, x, s.states, u_prev, s.inputs) != GHM_STATUS_OK)
        return fail("start");

    printf("k");
    for (size_t i = 0; i < s.states; i++)
        printf(",x_%s", ghm_controller_name(c, GHM_QUANTITY_STATE, i));
    for (size_t i = 0; i < s.inputs; i++)
        printf(",u_%s", ghm_controller_name(c, GHM_QUANTITY_INPUT, i));
    printf(",iterations,solve_ms,fallback\n");

    for (size_t k = 0; k < steps; k++) {
        /* As a season gives it: every row left from step k. */
        const double *forecast = w.values + k * w.width;
        size_t n_forecast = (w.rows - k) * w.width;
        GhmDecision d;
        if (ghm_controller_decide(c, k, x, s.states, u_prev, s.inputs, forecast, n_forecast, u,
                                  s.inputs, &d) != GHM_STATUS_OK)
            return fail("decide");
        printf("%zu", k);
        for (size_t i = 0; i < s.states; i++)
            printf(",%.17g", x[i]);
        for (size_t i = 0; i < s.inputs; i++)
            printf(",%.17g", u[i]);
        printf(",%zu,%.3f,%d\n", d.iterations, d.solve_time_s * 1e3, d.fallback ? 1 : 0);
        if (ghm_controller_plant_step(c, x, s.states, u, s.inputs, forecast, w.width, next,
                                      s.states) != GHM_STATUS_OK)
            return fail("plant step");
        memcpy(x, next, s.states * sizeof(double));
        memcpy(u_prev, u, s.inputs * sizeof(double));
    }
    fprintf(stderr, "%zu steps; final %s = %.6g\n", steps,
            ghm_controller_name(c, GHM_QUANTITY_STATE, 0), x[0]);
    ghm_controller_free(c);
    free(x);
    free(next);
    free(u);
    free(u_prev);
    free(w.values);
    return 0;
}
