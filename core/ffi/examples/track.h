/* What the C examples that drive an actor from an OpenFace 2.0 track share (drive.c, live.c):
 * reading the track's rows, on top of what every example shares (example.h). Static functions in
 * a header, so that each example stays one translation unit. */
#ifndef SINEW_EXAMPLE_TRACK_H
#define SINEW_EXAMPLE_TRACK_H

#include "example.h"

#define MAX_ROWS 1024
#define MAX_LINE 16384
#define LANDMARKS 68

/* The rows of an OpenFace 2.0 CSV: each row's timestamp, whether the tracker found the face
 * (the success column, where `found` is not NULL) and its 68 [u, v] pixels (from the x_0 .. x_67
 * and y_0 .. y_67 columns, found by the header's names). Returns the row count, or -1 on an
 * error (printed, naming the file and the row). */
static int read_track(const char *path, float *times, int *found,
                      float (*pixels)[2 * LANDMARKS]) {
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        fprintf(stderr, "%s: cannot open\n", path);
        return -1;
    }
    static char line[MAX_LINE];
    int time_col = -1, success_col = -1, x0 = -1, y0 = -1, rows = 0, bad = 0;
    if (fgets(line, sizeof line, f) != NULL) {
        int col = 0;
        for (char *cell = strtok(line, ",\r\n"); cell != NULL; cell = strtok(NULL, ",\r\n")) {
            while (*cell == ' ') {
                cell++;
            }
            if (strcmp(cell, "timestamp") == 0) {
                time_col = col;
            } else if (strcmp(cell, "success") == 0) {
                success_col = col;
            } else if (strcmp(cell, "x_0") == 0) {
                x0 = col;
            } else if (strcmp(cell, "y_0") == 0) {
                y0 = col;
            }
            col++;
        }
    }
    if (time_col < 0 || success_col < 0 || x0 < 0 || y0 < 0) {
        fprintf(stderr, "%s: the header has no timestamp, success, x_0 or y_0 column\n", path);
        fclose(f);
        return -1;
    }
    while (!bad && fgets(line, sizeof line, f) != NULL) {
        if (rows == MAX_ROWS) {
            fprintf(stderr, "%s: more than %d rows\n", path, MAX_ROWS);
            bad = 1;
            break;
        }
        int col = 0, got = 0;
        for (char *cell = strtok(line, ",\r\n"); cell != NULL; cell = strtok(NULL, ",\r\n")) {
            char *end = NULL;
            /* strtof rounds the decimal text to the nearest float, as Rust's parser does. */
            float v = strtof(cell, &end);
            int is_number = end != cell;
            if (col == success_col && found != NULL) {
                found[rows] = is_number && v != 0.0f;
            } else if (col == time_col || (col >= x0 && col < x0 + LANDMARKS) ||
                       (col >= y0 && col < y0 + LANDMARKS)) {
                if (!is_number) {
                    fprintf(stderr, "%s: row %d, column %d: not a number\n", path, rows + 2, col);
                    bad = 1;
                    break;
                }
                if (col == time_col) {
                    times[rows] = v;
                } else if (col < x0 + LANDMARKS && col >= x0) {
                    pixels[rows][2 * (col - x0)] = v;
                } else {
                    pixels[rows][2 * (col - y0) + 1] = v;
                }
                got++;
            }
            col++;
        }
        if (!bad && got != 1 + 2 * LANDMARKS) {
            fprintf(stderr, "%s: row %d has %d of the %d values\n", path, rows + 2, got,
                    1 + 2 * LANDMARKS);
            bad = 1;
        }
        rows++;
    }
    fclose(f);
    return bad ? -1 : rows;
}

#endif
