; Per-layout overrides (front-end test): a mail robot; the big layout has a third desk.
(define (domain mailroom)
  (:requirements :typing :action-costs)
  (:types desk letter)
  (:predicates (robot-at ?d - desk) (at ?l - letter ?d - desk) (holding ?l - letter) (hand-free))
  (:functions (total-cost) - number)
  (:action move
    :parameters (?from ?to - desk)
    :precondition (robot-at ?from)
    :effect (and (not (robot-at ?from)) (robot-at ?to) (increase (total-cost) 2)))
  (:action pick
    :parameters (?l - letter ?d - desk)
    :precondition (and (hand-free) (robot-at ?d) (at ?l ?d))
    :effect (and (not (hand-free)) (holding ?l) (not (at ?l ?d)) (increase (total-cost) 1)))
  (:action drop
    :parameters (?l - letter ?d - desk)
    :precondition (and (holding ?l) (robot-at ?d))
    :effect (and (hand-free) (not (holding ?l)) (at ?l ?d) (increase (total-cost) 1))))
