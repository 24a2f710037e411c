/* What every C example shares (replay.c, drive.c, live.c): reading a file whole and reporting a
 * failed call. Static functions in a header, so that each example stays one translation unit. */
#ifndef SINEW_EXAMPLE_H
#define SINEW_EXAMPLE_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sinew.h"

/* Reads a whole file into a malloc'd buffer, aligned for the library (malloc aligns to at least
 * 8 bytes); the handles borrow it, so it is freed only after them. */
static uint8_t *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        fprintf(stderr, "%s: cannot open\n", path);
        return NULL;
    }
    uint8_t *bytes = NULL;
    long size = -1;
    if (fseek(f, 0, SEEK_END) == 0) {
        size = ftell(f);
    }
    if (size >= 0 && fseek(f, 0, SEEK_SET) == 0) {
        bytes = malloc(size > 0 ? (size_t)size : 1);
        if (bytes != NULL && fread(bytes, 1, (size_t)size, f) != (size_t)size) {
            free(bytes);
            bytes = NULL;
        }
    }
    fclose(f);
    if (bytes == NULL) {
        fprintf(stderr, "%s: cannot read\n", path);
        return NULL;
    }
    *len = (size_t)size;
    return bytes;
}

/* Prints a failed call's message; returns 1 on failure, 0 on success. */
static int failed(SinewStatus status, const SinewError *err, const char *what) {
    if (status == SINEW_STATUS_OK) {
        return 0;
    }
    fprintf(stderr, "%s: %s (status %d)\n", what, err->message, (int)status);
    return 1;
}

#endif
