; Task 1 clears receptacle C with the hand free; task 2 delivers the apple.
(define (domain minimal-tasks)
  (:requirements :typing :negative-preconditions :existential-preconditions)

  (:action clear
    :parameters (?r - cell)
    :precondition (and (hand-free) (not (exists (?t - thing) (at ?t ?r))))
    :effect (and))

  (:action deliver
    :parameters (?r - cell ?t - fruit)
    :precondition (at ?t ?r)
    :effect (and)))
