/*
 * predict.c: `drive predict` in C, through the C library (drive.h).
 *
 *     predict MODEL_FILE COMMANDS_CSV
 *
 * prints exactly what `drive predict --model MODEL_FILE --commands COMMANDS_CSV` prints:
 * the header k,t,x,y,yaw (and the six covariance columns for a model with an uncertainty)
 * and one row per command, from rest at the origin, every number written as the command
 * line writes it (the shortest decimal that reads back as the same double; scientific
 * notation below 1e-4 and from 1e16). The command file: the header t,<the model's command
 * columns> (t,cmd_left,cmd_right for a differential drive), one row per command at the
 * model's command period.
 *
 * Build (after `cargo build --release -p drive-capi`):
 *     cc -O2 -o predict examples/capi/predict.c -Idrive-capi/include \
 *        -Ltarget/release -ldrive_capi -Wl,-rpath,$PWD/target/release
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drive.h"

/* As the command line: lines of at most 4096 bytes, at most 1,000,000 commands, values
 * within 1e9. */
#define MAX_LINE 4096
#define MAX_COMMANDS 1000000
#define MAX_VALUE 1e9

static int fail(const char *what) {
    fprintf(stderr, "error: %s\n", what);
    return 1;
}

/* The shortest decimal digits of v (finite, nonzero) that read back as v: `digits` (no
 * dot) and the decimal exponent of the first digit. */
static void shortest(double v, char *digits, int *exponent) {
    char buf[64];
    for (int p = 1; p <= 17; p++) {
        snprintf(buf, sizeof buf, "%.*e", p - 1, v);
        if (strtod(buf, NULL) == v) {
            break;
        }
    }
    /* buf: [-]d[.ddd]e[+-]xx */
    const char *s = buf[0] == '-' ? buf + 1 : buf;
    size_t n = 0;
    for (; *s && *s != 'e'; s++) {
        if (*s != '.') {
            digits[n++] = *s;
        }
    }
    while (n > 1 && digits[n - 1] == '0') {
        n--;
    }
    digits[n] = '\0';
    *exponent = atoi(s + 1);
}

/* v as the command line prints it (Rust's Display, or its LowerExp below 1e-4 and from
 * 1e16). */
static void format_number(double v, char *out) {
    if (v == 0.0) {
        strcpy(out, signbit(v) ? "-0" : "0");
        return;
    }
    char digits[32];
    int e;
    shortest(v, digits, &e);
    char *o = out;
    if (v < 0) {
        *o++ = '-';
    }
    size_t n = strlen(digits);
    double a = fabs(v);
    if (a < 1e-4 || a >= 1e16) {
        *o++ = digits[0];
        if (n > 1) {
            *o++ = '.';
            memcpy(o, digits + 1, n - 1);
            o += n - 1;
        }
        sprintf(o, "e%d", e);
        return;
    }
    if (e >= 0) {
        for (int i = 0; i <= e; i++) {
            *o++ = (size_t)i < n ? digits[i] : '0';
        }
        if ((size_t)(e + 1) < n) {
            *o++ = '.';
            for (size_t i = (size_t)e + 1; i < n; i++) {
                *o++ = digits[i];
            }
        }
    } else {
        *o++ = '0';
        *o++ = '.';
        for (int i = 0; i < -e - 1; i++) {
            *o++ = '0';
        }
        memcpy(o, digits, n);
        o += n;
    }
    *o = '\0';
}

static char *trim(char *s) {
    while (*s == ' ' || *s == '\t' || *s == '\n' || *s == '\r' || *s == '\v' || *s == '\f') {
        s++;
    }
    char *end = s + strlen(s);
    while (end > s && (end[-1] == ' ' || end[-1] == '\t' || end[-1] == '\n' || end[-1] == '\r' ||
                       end[-1] == '\v' || end[-1] == '\f')) {
        *--end = '\0';
    }
    return s;
}

int main(int argc, char **argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: %s MODEL_FILE COMMANDS_CSV\n", argv[0]);
        return 2;
    }
    char message[MAX_LINE + 256];
    drive_model *model = NULL;
    if (drive_model_load(argv[1], &model) != DRIVE_OK) {
        return fail(drive_last_error());
    }
    size_t dim = drive_model_input_count(model);
    double dt = drive_model_dt(model);

    FILE *f = fopen(argv[2], "r");
    if (!f) {
        snprintf(message, sizeof message, "reading %s: %s", argv[2], strerror(errno));
        return fail(message);
    }
    /* The expected header: t, then the model's command columns. */
    char expected[MAX_LINE] = "t";
    for (size_t i = 0; i < dim; i++) {
        strncat(expected, ",", sizeof expected - strlen(expected) - 1);
        strncat(expected, drive_model_command_column(model, i), sizeof expected - strlen(expected) - 1);
    }
    double *commands = NULL;
    size_t count = 0, capacity = 0;
    double t0 = 0.0;
    int header_seen = 0;
    char line[MAX_LINE + 2];
    size_t number = 0;
    while (fgets(line, sizeof line, f)) {
        number++;
        size_t len = strlen(line);
        if (len > MAX_LINE || (len == MAX_LINE + 1 && line[len - 1] != '\n')) {
            snprintf(message, sizeof message, "%s, line %zu: longer than %d bytes: not a command file", argv[2], number, MAX_LINE);
            return fail(message);
        }
        char *l = line;
        if (!header_seen && strncmp(l, "\xEF\xBB\xBF", 3) == 0) {
            l += 3; /* a byte-order mark */
        }
        char *body = trim(l);
        if (*body == '\0') {
            continue;
        }
        if (!header_seen) {
            /* Columns compared trimmed, as the command line does. */
            char copy[MAX_LINE + 2], joined[MAX_LINE + 2] = "";
            strcpy(copy, body);
            for (char *tok = strtok(copy, ","); tok; tok = strtok(NULL, ",")) {
                if (joined[0]) {
                    strcat(joined, ",");
                }
                strcat(joined, trim(tok));
            }
            if (strcmp(joined, expected) != 0) {
                snprintf(message, sizeof message, "%s, line %zu: expected the header '%s', found '%s'", argv[2], number, expected, body);
                return fail(message);
            }
            header_seen = 1;
            continue;
        }
        double v[4] = {0, 0, 0, 0};
        size_t fields = 0;
        char *p = body;
        for (;;) {
            char *comma = strchr(p, ',');
            if (comma) {
                *comma = '\0';
            }
            if (fields < dim + 1) {
                char *text = trim(p), *end = NULL;
                double x = strtod(text, &end);
                if (*text == '\0' || *end != '\0') {
                    snprintf(message, sizeof message, "%s, line %zu: '%s' is not a number", argv[2], number, text);
                    return fail(message);
                }
                if (!isfinite(x) || fabs(x) > MAX_VALUE) {
                    snprintf(message, sizeof message, "%s, line %zu: '%s' is not a finite number within 1e9", argv[2], number, text);
                    return fail(message);
                }
                v[fields] = x;
            }
            fields++;
            if (!comma) {
                break;
            }
            p = comma + 1;
        }
        if (fields != dim + 1) {
            snprintf(message, sizeof message, "%s, line %zu: %zu fields where the header has %zu", argv[2], number, fields, dim + 1);
            return fail(message);
        }
        if (count == 0) {
            t0 = v[0];
        }
        double t = t0 + (double)count * dt;
        if (fabs(v[0] - t) > 0.5 * dt) {
            snprintf(message, sizeof message, "%s, line %zu: t is off the model's command period of %g s", argv[2], number, dt);
            return fail(message);
        }
        if (count == MAX_COMMANDS) {
            snprintf(message, sizeof message, "%s, line %zu: more than %d commands", argv[2], number, MAX_COMMANDS);
            return fail(message);
        }
        if (count == capacity) {
            capacity = capacity ? 2 * capacity : 1024;
            commands = realloc(commands, capacity * dim * sizeof(double));
            if (!commands) {
                return fail("out of memory");
            }
        }
        for (size_t i = 0; i < dim; i++) {
            commands[count * dim + i] = v[1 + i];
        }
        count++;
    }
    fclose(f);
    if (!header_seen) {
        snprintf(message, sizeof message, "%s: the file is empty", argv[2]);
        return fail(message);
    }
    if (count == 0) {
        snprintf(message, sizeof message, "%s: no command rows", argv[2]);
        return fail(message);
    }

    drive_start start;
    drive_start_rest(&start);
    int with_cov = drive_model_has_uncertainty(model) == 1;
    double *poses = malloc(count * 3 * sizeof(double));
    double *covs = with_cov ? malloc(count * 9 * sizeof(double)) : NULL;
    if (!poses || (with_cov && !covs)) {
        return fail("out of memory");
    }
    if (drive_predict(model, &start, commands, count, poses, covs) != DRIVE_OK) {
        return fail(drive_last_error());
    }

    printf("k,t,x,y,yaw%s\n", with_cov ? ",cov_xx,cov_xy,cov_xyaw,cov_yy,cov_yyaw,cov_yawyaw" : "");
    double rate_hz = 1.0 / dt;
    char a[64];
    for (size_t k = 0; k < count; k++) {
        printf("%zu", k);
        double row[9] = {t0 + (double)k / rate_hz, poses[3 * k], poses[3 * k + 1], poses[3 * k + 2]};
        size_t n = 4;
        if (with_cov) {
            const double *c = covs + 9 * k;
            row[4] = c[0]; /* xx */
            row[5] = c[1]; /* xy */
            row[6] = c[2]; /* x yaw */
            row[7] = c[4]; /* yy */
            row[8] = c[5]; /* y yaw */
            n = 9;
            /* yaw yaw */
        }
        for (size_t i = 0; i < n; i++) {
            format_number(row[i], a);
            printf(",%s", a);
        }
        if (with_cov) {
            format_number(covs[9 * k + 8], a);
            printf(",%s", a);
        }
        printf("\n");
    }
    free(poses);
    free(covs);
    free(commands);
    drive_model_free(model);
    return 0;
}
