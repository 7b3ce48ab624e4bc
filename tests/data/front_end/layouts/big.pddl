; The small layout plus desk d3.
(define (problem big)
  (:domain mailroom)
  (:objects d1 d2 d3 - desk letter_0 - letter)
  (:init (robot-at d1) (hand-free) (at letter_0 d1))
  (:goal (and)))
