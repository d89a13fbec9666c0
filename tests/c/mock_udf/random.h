/* A mock of Fluent's random.h: the uniform generator fluent_udf.c draws from. */
#ifndef MOCK_FLUENT_RANDOM_H
#define MOCK_FLUENT_RANDOM_H

float uniform_random(void);

#endif /* MOCK_FLUENT_RANDOM_H */
