; The persistent 2-D blockworld of Dhakal, Nguyen and Stein (ICAPS 2023), abstracted
; to its regions: a robot arm moves between ten regions (seven coloured goal regions,
; three white parking regions), each holding at most one block, and picks and places
; eight blocks. The grid survives only in each layout's move-cost table (25 per unit
; of path length between two regions, as each layout file says); pick and place cost
; 100 each.
(define (domain blockworld)
  (:requirements :typing :equality :negative-preconditions
                 :existential-preconditions :universal-preconditions :action-costs)
  (:types
    region block job - object
    colored-region white-region - region   ; white regions are never a task's target
    colored-block white-block - block      ; white blocks are never a task's subject
    single-job pair-job - job)             ; a layout's task library, one object per task

  (:predicates
    (robot-at ?r - region)
    (hand-free)
    (holding ?b - block)
    (at ?b - block ?r - region)            ; a held block is at no region
    ; static facts of a layout: what each task of its library asks for
    (wants ?j - job ?b - colored-block ?r - colored-region))

  (:functions
    (total-cost) - number
    (move-cost ?from ?to - region) - number)

  (:action move
    :parameters (?from ?to - region)
    :precondition (and (robot-at ?from) (not (= ?from ?to)))
    :effect (and (not (robot-at ?from)) (robot-at ?to)
                 (increase (total-cost) (move-cost ?from ?to))))

  (:action pick
    :parameters (?b - block ?r - region)
    :precondition (and (hand-free) (robot-at ?r) (at ?b ?r))
    :effect (and (not (hand-free)) (holding ?b) (not (at ?b ?r))
                 (increase (total-cost) 100)))

  ; A region holds one block: placing needs it empty.
  (:action place
    :parameters (?b - block ?r - region)
    :precondition (and (holding ?b) (robot-at ?r)
                       (not (exists (?x - block) (at ?x ?r))))
    :effect (and (hand-free) (not (holding ?b)) (at ?b ?r)
                 (increase (total-cost) 100))))
