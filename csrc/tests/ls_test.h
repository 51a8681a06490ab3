/* Minimal test harness for the C unit tests: counts checks, prints failures and a closing
 * line "N passed, N failed". */
#ifndef LS_TEST_H
#define LS_TEST_H

#include <math.h>
#include <stdio.h>

static int ls_test_passed;
static int ls_test_failed;

#define LS_CHECK(cond)                                                                      \
    do {                                                                                    \
        if (cond) {                                                                         \
            ++ls_test_passed;                                                               \
        } else {                                                                            \
            ++ls_test_failed;                                                               \
            printf("FAIL %s:%d: %s\n", __FILE__, __LINE__, #cond);                          \
        }                                                                                   \
    } while (0)

#define LS_CHECK_NEAR(a, b, tol)                                                            \
    do {                                                                                    \
        double ls_a_ = (double)(a), ls_b_ = (double)(b);                                    \
        if (fabs(ls_a_ - ls_b_) <= (double)(tol)) {                                         \
            ++ls_test_passed;                                                               \
        } else {                                                                            \
            ++ls_test_failed;                                                               \
            printf("FAIL %s:%d: %s = %.9g, %s = %.9g, tol %.3g\n", __FILE__, __LINE__, #a,  \
                   ls_a_, #b, ls_b_, (double)(tol));                                        \
        }                                                                                   \
    } while (0)

static int ls_test_report(const char *name)
{
    printf("%s: %d passed, %d failed\n", name, ls_test_passed, ls_test_failed);
    return ls_test_failed == 0 ? 0 : 1;
}

#endif /* LS_TEST_H */
